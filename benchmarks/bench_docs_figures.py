"""Time each guide's figure: the code of every ``.. plot::`` block of the guides, run as the
documentation build runs it (one process, in order, Agg backend).

Run: ``python benchmarks/bench_docs_figures.py [--repeat 2]``. The guides are the pages of the
"Guides" toctree of ``docs/index.md``; the first pass pays the imports (and any compilation the
kernel cache does not hold), later passes are what a rebuild of the site costs per figure.
Results: ``benchmarks/RESULTS.md``, "Documentation figures".
"""

from __future__ import annotations

import argparse
import os
import re
import textwrap
import time
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

DOCS = Path(__file__).resolve().parents[1] / "docs"


def guide_pages() -> list[str]:
    """The pages of the "Guides" toctree of docs/index.md."""
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    block = re.search(r"```\{toctree\}\n(?::[^\n]*\n)*?:caption: Guides\n(.*?)```", index, flags=re.S)
    if block is None:
        raise SystemExit("docs/index.md has no toctree captioned Guides")
    return [line.strip() for line in block.group(1).splitlines() if line.strip() and not line.startswith(":")]


def plot_blocks(page: str) -> list[str]:
    """The code of every ``.. plot::`` block (inside an eval-rst fence) of a page."""
    text = (DOCS / f"{page}.md").read_text(encoding="utf-8")
    return [textwrap.dedent(m.group(1)) for m in re.finditer(r"```\{eval-rst\}\n\.\. plot::\n\n(.*?)\n```", text,
                                                              flags=re.S)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="passes over all figures (default 2)")
    args = parser.parse_args()
    import matplotlib.pyplot as plt

    pages = {page: plot_blocks(page) for page in guide_pages()}
    times: dict[str, list[float]] = {page: [] for page in pages}
    for _ in range(args.repeat):
        for page, blocks in pages.items():
            t0 = time.perf_counter()
            for code in blocks:
                exec(compile(code, f"docs/{page}.md", "exec"), {"__name__": "__main__"})
                plt.close("all")
            times[page].append(time.perf_counter() - t0)
    print("| guide | figures | " + " | ".join(f"pass {k + 1} [s]" for k in range(args.repeat)) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in range(args.repeat)) + " |")
    for page, ts in times.items():
        print(f"| {page} | {len(pages[page])} | " + " | ".join(f"{t:.2f}" for t in ts) + " |")
    print("| all | " + str(sum(len(b) for b in pages.values())) + " | "
          + " | ".join(f"{sum(ts[k] for ts in times.values()):.1f}" for k in range(args.repeat)) + " |")


if __name__ == "__main__":
    main()
