"""Entry point of the ``gaitstudio`` command."""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Start Gait Studio. The window itself arrives with issue #5."""
    del argv
    print("gaitstudio: the desktop application is not built yet (issue #5); "
          "use the 'gaitcore' command meanwhile", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
