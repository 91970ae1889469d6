# The farm's worker (and client) image: Debian with CalculiX, the package installed.
#   docker compose build && docker compose up --scale worker=8
FROM python:3.11-slim-bookworm

# ccx from Debian (calculix-ccx 2.20); the rest are gmsh's shared-library needs
RUN apt-get update \
 && apt-get install -y --no-install-recommends calculix-ccx libglu1-mesa libgl1 \
      libxcursor1 libxft2 libxinerama1 libxrender1 libfontconfig1 libgomp1 \
 && rm -rf /var/lib/apt/lists/*

WORKDIR /opt/tyre-farm
COPY pyproject.toml README.md ./
COPY farm farm
COPY jobs jobs
COPY storage storage
COPY analysis analysis
RUN pip install --no-cache-dir . && farm --help >/dev/null && ccx -v

# solver scratch inside the container; results go to the shared /work/results
ENV FARM_SCRATCH_DIR=/tmp/ccx FARM_CACHE_DIR=/tmp/tyre-farm-cache
WORKDIR /work
