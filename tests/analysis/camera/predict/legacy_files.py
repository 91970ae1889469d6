"""Model files as the farm saved them before issue 49 moved the camera's types into
``analysis/camera/``: skops names a type by its module, so such a file's schema says
``analysis.learners.PLSCV`` and ``analysis.predict.intervals.ConformalIntervals``.

:func:`saved_before_the_move` turns a file this farm wrote into one: the same bytes but
for the modules in its schema (skops writes ``schema.json`` with ``json.dumps(indent=2)``,
and so does this), and the manifest's checksum of those bytes, as the old farm wrote it.
The old modules are written out here, not read from the code under test
(``analysis.camera.predict.persist.LEGACY_TYPES``), so a wrong name there fails the tests.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from pathlib import Path

#: where the moved types lived before issue 49
OLD_MODULES = {"analysis.camera.learners": "analysis.learners",
               "analysis.camera.predict.intervals": "analysis.predict.intervals"}
OLD_NAMES = ("analysis.learners.GPOnScores", "analysis.learners.PLSCV",
             "analysis.predict.intervals.ConformalIntervals")


def with_old_modules(data: bytes) -> bytes:
    """A skops file (bytes) whose schema names the moved types by their old modules."""
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        schema = json.loads(zf.read("schema.json"))
        stack = [schema]
        while stack:
            node = stack.pop()
            if isinstance(node, list):
                stack.extend(node)
            elif isinstance(node, dict):
                if node.get("__module__") in OLD_MODULES:
                    node["__module__"] = OLD_MODULES[node["__module__"]]
                stack.extend(node.values())
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w") as new:
            for info in zf.infolist():
                new.writestr(info, json.dumps(schema, indent=2).encode()
                             if info.filename == "schema.json" else zf.read(info))
    return out.getvalue()


def saved_before_the_move(path: Path) -> Path:
    """Rewrite the model directory or ``.zip`` at ``path`` (written by ``save_model``) in
    place as the farm before issue 49 wrote it; ``path``."""
    path = Path(path)
    if path.is_dir():
        data = with_old_modules((path / "model.skops").read_bytes())
        manifest = json.loads((path / "manifest.json").read_text())
        manifest["model_sha256"] = hashlib.sha256(data).hexdigest()
        (path / "model.skops").write_bytes(data)
        (path / "manifest.json").write_text(json.dumps(manifest, indent=2))
        return path
    with zipfile.ZipFile(path) as zf:
        data = with_old_modules(zf.read("model.skops"))
        manifest = json.loads(zf.read("manifest.json"))
    manifest["model_sha256"] = hashlib.sha256(data).hexdigest()
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zf:
        zf.writestr("model.skops", data, compress_type=zipfile.ZIP_STORED)
        zf.writestr("manifest.json", json.dumps(manifest, indent=2),
                    compress_type=zipfile.ZIP_DEFLATED)
    path.write_bytes(buffer.getvalue())
    return path
