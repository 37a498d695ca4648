"""``python -m mckibben.control.laws [PATH]``: write ``firmware/core/laws.h`` from the table.

PATH defaults to the source tree's ``firmware/core/laws.h``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mckibben.control.laws import c_header

if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[4] / "firmware" / "core" / "laws.h"
    out.write_text(c_header(), encoding="utf-8")
    print(out)
