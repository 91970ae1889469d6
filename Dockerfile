# The farm's image (scheduler, workers and client alike): Debian bookworm with Python and
# CalculiX from apt, the project in a venv at /opt/venv, run as the non-root user `farm`.
#   podman build --network host -t tyre-farm:latest .     (or: docker build -t tyre-farm .)
#   podman-compose up -d --scale worker=2                  (see docker-compose.yml)
# Tested end to end by scripts/test-cluster.sh; docs/scale-out.md explains the cluster.
FROM debian:bookworm-slim

# python3 (3.11) + venv; ccx (Debian's calculix-ccx 2.20); gmsh's shared-library needs
# (the same list as scripts/setup.sh); CA certificates for object stores over TLS (s3).
ARG DEBIAN_FRONTEND=noninteractive
RUN apt-get update \
 && apt-get install -y --no-install-recommends python3 python3-venv calculix-ccx \
      libglu1-mesa libgl1 libxcursor1 libxft2 libxinerama1 libxrender1 libfontconfig1 \
      libgomp1 libx11-6 ca-certificates \
 && apt-get clean && rm -rf /var/lib/apt/lists/* /var/cache/apt/archives/*

RUN python3 -m venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 \
    PYTHONDONTWRITEBYTECODE=1

# The dependencies first, read from pyproject.toml (core + the extras a cluster needs), so
# that a change to the code alone rebuilds in seconds, not minutes.
ARG FARM_EXTRAS="s3"
WORKDIR /opt/tyre-farm
COPY pyproject.toml README.md ./
RUN python -c "import sys, tomllib; p = tomllib.load(open('pyproject.toml', 'rb'))['project']; \
extras = p.get('optional-dependencies', {}); \
print('\n'.join(p['dependencies'] + [d for e in sys.argv[1:] for d in extras[e]]))" \
      $FARM_EXTRAS > /tmp/requirements.txt \
 && pip install -r /tmp/requirements.txt && rm /tmp/requirements.txt

# Every package of the project (the `farm` console script is tyre_farm_cli:main) and the examples.
COPY farm farm
COPY jobs jobs
COPY storage storage
COPY analysis analysis
COPY tyre_farm_cli tyre_farm_cli
COPY examples examples
RUN pip install --no-deps . && rm -rf build *.egg-info && pip check

# Build-time check that the image works: the CLI starts, gmsh's libraries load and ccx
# solves a one-element deck (`ccx -v` is no check: Debian's 2.20 exits 201 after printing
# its version).
RUN farm --help >/dev/null \
 && python -c "import gmsh; gmsh.initialize(); gmsh.finalize()" \
 && mkdir /tmp/ccx-check && cd /tmp/ccx-check \
 && printf '%s\n' '*NODE' '1,0,0,0' '2,1,0,0' '3,1,1,0' '4,0,1,0' '5,0,0,1' '6,1,0,1' \
      '7,1,1,1' '8,0,1,1' '*ELEMENT,TYPE=C3D8,ELSET=E' '1,1,2,3,4,5,6,7,8' '*BOUNDARY' \
      '1,1,3' '2,2,3' '3,3,3' '4,1,1' '4,3,3' '*MATERIAL,NAME=M' '*ELASTIC' '1000,0.3' \
      '*SOLID SECTION,ELSET=E,MATERIAL=M' '*STEP' '*STATIC' '*CLOAD' '5,3,1.' '6,3,1.' \
      '7,3,1.' '8,3,1.' '*NODE FILE' 'U' '*END STEP' > cube.inp \
 && ccx -i cube >/dev/null && grep -q DISP cube.frd \
 && cd / && rm -rf /tmp/ccx-check

# A non-root user; /work is the working folder (compose bind-mounts the host's there).
RUN useradd --uid 1000 --user-group --create-home --shell /bin/bash farm \
 && mkdir -p /work/results && chown -R farm:farm /work
USER farm
# solver scratch and mesh cache inside the container (fast, private); results go to /work
ENV FARM_SCRATCH_DIR=/tmp/ccx FARM_CACHE_DIR=/tmp/tyre-farm-cache
WORKDIR /work
CMD ["farm", "--help"]
