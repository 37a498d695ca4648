"""``mckibben datasets list|generate``: the bundled example campaign (SYNTHETIC)."""

from __future__ import annotations

from pathlib import Path

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, console, emit_json, print_table
from mckibben.errors import InputError
from mckibben import data, datasets

datasets_app = typer.Typer(help="The bundled example campaign (synthetic) and published sets.", no_args_is_help=True)
app.add_typer(datasets_app, name="datasets")


@datasets_app.command("list")
def list_cmd(json: bool = JSON_OPTION) -> None:
    """List the bundled campaign's muscles and files, and the published parameter sets."""

    files = []
    for folder in datasets.campaign.campaign_muscle_dirs(datasets.campaign.BUNDLED):
        spec = data.read_muscle(folder / "muscle.toml")
        for f in sorted(folder.iterdir()):
            if f.suffix in (".csv", ".parquet"):
                t = data.read_table(f)
                files.append({"muscle": spec.id, "file": str(f), "kind": t.kind, "rows": len(t),
                              "trials": int(t.data["trial"].nunique()), "size_bytes": f.stat().st_size})

    for folder in sorted(p for p in datasets.isometric.BUNDLED_ISOMETRIC.iterdir() if (p / "muscle.toml").is_file()):
        spec = data.read_muscle(folder / "muscle.toml")
        for f in sorted(folder.glob("*.csv")):
            t = data.read_table(f)
            files.append({"muscle": spec.id, "file": str(f), "kind": t.kind, "rows": len(t),
                          "trials": int(t.data["trial"].nunique()), "size_bytes": f.stat().st_size,
                          "synthetic": bool(spec.synthetic)})
    out = {"campaign": str(datasets.campaign.BUNDLED), "synthetic": datasets.campaign.is_synthetic(datasets.campaign.BUNDLED), "files": files,
           "published_sets": list(datasets.MUSCLES)}
    if json:
        emit_json(out)
        return
    console.print(f"[bold yellow]SYNTHETIC[/] example campaign in {datasets.campaign.BUNDLED} and a SYNTHETIC isometric test of a "
                  "commercial-size muscle (commercial10) (generated, not measured)")
    print_table("Bundled campaign", [" muscle", " kind", "rows", "trials", "bytes", " file"],
                [[f["muscle"], f["kind"], str(f["rows"]), str(f["trials"]), str(f["size_bytes"]), Path(f["file"]).name]
                 for f in files])
    console.print(f"Published parameter sets: {', '.join(datasets.MUSCLES)} (mckibben params list)")


@datasets_app.command("generate")
def generate_cmd(
    out: Path = typer.Option(Path("mckibben-campaign"), "--out", help="Folder to write (default ./mckibben-campaign)."),
    seed: int = typer.Option(0, "--seed", help="Random seed; the bundled campaign is seed 0."),
    json: bool = JSON_OPTION,
) -> None:
    """Generate the example campaign (deterministic for a seed) from the published parameter sets."""

    if seed < 0:
        raise InputError(f"--seed: {seed} must be >= 0")
    folder = datasets.campaign.write_campaign(out, seed)
    files = sorted(str(p) for p in folder.rglob("*") if p.is_file())
    if json:
        emit_json({"out": str(folder), "seed": seed, "synthetic": True, "files": files})
        return
    console.print(f"wrote SYNTHETIC campaign (seed {seed}) to {folder}: {len(files)} files")
