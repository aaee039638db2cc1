"""Write the EGM2008 coefficients the package ships: emorbit/data/egm2008_6.gfc.

    python scripts/data_egm2008.py [--check]

The zonal effect's ``model = "earth"`` (:mod:`emorbit.effects.zonal`) reads EGM2008's
coefficients to degree and order 6 from this file, so that a plain install needs no
heyoka. They are written, in ICGEM's ``.gfc`` format, from the table heyoka ships
(``heyoka.model.get_egm2008_CS``, ``get_egm2008_mu``, ``get_egm2008_a``; heyoka is
MPL-2.0 licensed) with ``repr`` of each double, so the file holds heyoka's values bit for
bit. EGM2008: N. K. Pavlis, S. A. Holmes, S. C. Kenyon, J. K. Factor, J. Geophys. Res. 117
(2012) B04406; NGA, approved for public release, tide-free.

``--check`` compares the shipped file with heyoka's table and exits 1 where they differ.
"""

from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

DEGREE = 6
PATH = pathlib.Path(__file__).resolve().parent.parent / "emorbit" / "data" / "egm2008_6.gfc"


def text() -> str:
    """The file's text, from heyoka's EGM2008 table."""
    import heyoka

    CS = np.asarray(heyoka.model.get_egm2008_CS(), float)
    lines = [
        "EGM2008 to degree and order 6, written by scripts/data_egm2008.py from the table heyoka ships",
        "(heyoka.model.get_egm2008_CS, get_egm2008_mu, get_egm2008_a; heyoka: MPL-2.0).",
        "EGM2008: N. K. Pavlis, S. A. Holmes, S. C. Kenyon, J. K. Factor, J. Geophys. Res. 117 (2012)",
        "B04406; National Geospatial-Intelligence Agency, approved for public release.",
        "",
        "product_type gravity_field",
        "modelname EGM2008",
        f"earth_gravity_constant {float(heyoka.model.get_egm2008_mu())!r}",
        f"radius {float(heyoka.model.get_egm2008_a())!r}",
        f"max_degree {DEGREE}",
        "norm fully_normalized",
        "tide_system tide_free",
        "key n m C S",
        "end_of_head",
    ]
    k = 0
    for n in range(2, DEGREE + 1):
        for m in range(n + 1):
            lines.append(f"gfc {n} {m} {float(CS[k, 0])!r} {float(CS[k, 1])!r}")
            k += 1
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare the shipped file with heyoka's table")
    args = parser.parse_args()
    new = text()
    if args.check:
        same = PATH.is_file() and PATH.read_text() == new
        print(f"{PATH}: {'the same as' if same else 'differs from'} heyoka's table")
        return 0 if same else 1
    PATH.write_text(new)
    print(f"wrote {PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
