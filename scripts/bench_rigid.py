"""Rigid-body benchmark: emorbit's step cost against the number of mass points, and emorbit
beside Basilisk (RK4 + GravityGradientEffector) and Exudyn (implicit generalized-alpha) in the
same process. See emorbit/bench_rigid.py for what is measured.

    python scripts/bench_rigid.py [--quick] [--json FILE]

Peers are optional: pip install -e ".[rigid-peers]" (bsk, exudyn); a missing one is reported
as skipped. The full run takes about two minutes on a 2-core machine, --quick about 30 s.
"""

from __future__ import annotations

import argparse
import json
import sys


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="fewer sizes, shorter repeats (about 30 s)")
    p.add_argument("--json", metavar="FILE", help="also write the section as JSON")
    args = p.parse_args(argv)

    from emorbit import bench_rigid

    section = bench_rigid.run(quick=args.quick)
    print(bench_rigid.table(section))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(section, f, indent=1)
            f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
