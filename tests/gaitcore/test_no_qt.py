"""gaitcore must work on a machine without any Qt binding (README.md, Layout; an import-linter
contract too)."""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    import importlib, pkgutil, sys

    class BlockQt:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in {"PySide6", "PyQt5", "PyQt6", "PySide2", "pyqtgraph", "app"}:
                raise ImportError(f"{name} is blocked: gaitcore must not import Qt or the app")
            return None

    sys.meta_path.insert(0, BlockQt())
    import gaitcore
    names = [m.name for m in pkgutil.walk_packages(gaitcore.__path__, "gaitcore.")]
    for name in names:
        importlib.import_module(name)
    from gaitcore import ImagePCA, RBFPoseMap, select_key_images, diagnose
    print(len(names))
    """
)


def test_gaitcore_imports_without_qt():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout.strip()) >= 5
