"""The ``gaitcore pose`` subcommand: a key-pose CSV to start from, so that the command line
alone goes from footage to a BVH.

``gaitcore pose ANALYSIS.json --out KEYS.csv [--skeleton SKEL.json|SKEL.bvh]`` writes one row
per key-image and alternate of the analysis, ``frame`` then one column per channel of the
rig (``<joint>.rx``, ``.ry``, ``.rz`` in degrees, the root's ``.tx``, ``.ty``, ``.tz`` in
metres), each row the rig's rest pose: the artist edits the rows (in a spreadsheet, or from a
posed BVH) and passes the file to ``gaitcore animate --key-poses``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

TEMPLATE = "horse"
"""The rig used when no ``--skeleton`` is given."""


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``pose`` on an argparse subparsers object (``set_defaults(run=...)``)."""
    p = subparsers.add_parser(
        "pose",
        help="write a key-pose CSV to start from (the rig's rest pose for every key)",
        description="Write KEYS.csv for 'gaitcore animate --key-poses': one row per key-image "
        "and alternate of the analysis, 'frame' then one column per channel of the rig "
        "(rotations in degrees, the root's translations in metres), each the rig's rest pose. "
        "Edit the rows, then animate.",
    )
    p.add_argument("analysis", type=Path, help="analysis.json written by 'gaitcore analyze'")
    p.add_argument("--out", type=Path, required=True, metavar="KEYS.csv")
    p.add_argument("--skeleton", type=Path, default=None, metavar="SKEL.json|SKEL.bvh",
                   help=f"the rig whose channels the columns are (default: the {TEMPLATE} "
                   "template)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np  # here, not at import: building the parser loads none of the method

    from gaitcore.io.analysis_file import read_analysis_json
    from gaitcore.io.pose_table import PoseTable, write_pose_table
    from gaitcore.project.steps import read_rig
    from gaitcore.rig.templates import load_template

    record = read_analysis_json(args.analysis)
    if args.skeleton is None:
        skeleton = load_template(TEMPLATE)
    else:
        skeleton, note = read_rig(args.skeleton)
        if note:
            print(note)
    frames = record.key_frames + (record.alternate_frames or ())
    rest = skeleton.rest_pose()
    table = PoseTable(np.array(frames, dtype=int), tuple(skeleton.channel_names),
                      np.tile(rest, (len(frames), 1)))
    write_pose_table(args.out, table)
    alternates = (f" and alternates {list(record.alternate_frames)}"
                  if record.alternate_frames else "")
    print(f"wrote {args.out}: the rest pose ({len(rest)} channels) for keys "
          f"{list(record.key_frames)}{alternates}; pose each row, then run 'gaitcore animate "
          f"{args.analysis} --key-poses {args.out} --out curves.csv'")
    return 0
