"""Write the pages' numbers: run each command and keep its output under docs/_generated/.

Every number and figure on the documentation site comes from a command of this repository; this
script is that command for the site (``make docs-data``). It runs

* each guide snippet ``docs/snippets/*.py`` (the code shown on the page, run as shown);
* each paper claim ``verify/claim_*.py`` (``--quick`` with ``--quick``);
* each benchmark named in ``BENCHES`` (``--quick`` with ``--quick``);
* each notebook ``examples/*.ipynb``, executed with nbclient (``FL_DESIGN_QUICK=1`` with
  ``--quick``) and written as a gallery page ``docs/_generated/gallery/<name>.md`` with its
  figures as PNG files beside it;

and writes ``docs/_generated/<kind>_<name>.txt``: a first line naming the command, the machine
(CPU, cores, load) and the date, then the command's standard output. A command that fails or
times out writes its exit status and the end of its standard error instead of numbers: a page
never shows a number that no run produced.

Usage: ``python docs/generate.py [--quick] [--only NAME ...] [--timeout S]``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "_generated"
#: Benchmarks whose output the performance page shows.
BENCHES = ("bench_sweep", "bench_certify", "bench_codegen", "bench_tune", "bench_job",
           "bench_unseen", "bench_identify", "bench_step_cert", "bench_compile")
#: Extra arguments of a benchmark's run here (its full set of targets).
BENCH_ARGS = {"bench_certify": ["--classes"]}
#: Where each benchmark's target records go (``verify/_shared.py`` ``target``), one file per
#: script, replaced when the script runs again.
TARGETS = OUT / "targets"
#: The README's performance table lies between these two lines (written by :func:`readme_table`).
README_BEGIN = "<!-- performance table: written by `python docs/generate.py`, do not edit -->"
README_END = "<!-- end of the performance table -->"


def machine() -> str:
    """CPU model (:func:`fl_design._isa.cpu_model`), cores and the load average."""
    sys.path.insert(0, str(ROOT))
    from fl_design._isa import cpu_model

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{cpu_model()}, {os.cpu_count()} cores, load {load:.1f}"


def run(kind: str, script: Path, args: list[str], timeout: float) -> Path:
    cmd = [sys.executable, str(script.relative_to(ROOT)), *args]
    shown = " ".join(["python", *cmd[1:]])
    env = dict(os.environ, MPLBACKEND="Agg")
    if kind == "bench":
        TARGETS.mkdir(parents=True, exist_ok=True)
        records = TARGETS / f"{script.stem}.jsonl"
        records.unlink(missing_ok=True)  # this script's records from its previous run
        env["FL_DESIGN_TARGETS"] = str(records)
    try:
        p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                           timeout=timeout, check=False)
        body = p.stdout if p.returncode == 0 else (
            f"(exit status {p.returncode})\n{p.stdout}\n--- stderr (end) ---\n"
            + "\n".join(p.stderr.strip().splitlines()[-15:]) + "\n")
    except subprocess.TimeoutExpired:
        body = f"(timed out after {timeout:g} s: no numbers)\n"
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    path = OUT / f"{kind}_{script.stem}.txt"
    path.write_text(f"# `{shown}` on {machine()}, {stamp}\n{body}")
    return path


def notebook_page(nb_path: Path, quick: bool, timeout: float) -> Path:
    """Execute a notebook and write it as a MyST page with its outputs (text and PNG figures)."""
    import base64

    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(nb_path, as_version=4)
    env_before = os.environ.get("FL_DESIGN_QUICK")
    if quick:
        os.environ["FL_DESIGN_QUICK"] = "1"
    backend_before = os.environ.get("MPLBACKEND")
    os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"  # figures as PNG
    try:
        NotebookClient(nb, timeout=int(timeout), kernel_name="python3",
                       resources={"metadata": {"path": str(ROOT / "examples")}}).execute()
    finally:
        if env_before is None:
            os.environ.pop("FL_DESIGN_QUICK", None)
        if backend_before is None:
            os.environ.pop("MPLBACKEND", None)
        else:
            os.environ["MPLBACKEND"] = backend_before
    gal = OUT / "gallery"
    gal.mkdir(parents=True, exist_ok=True)
    stem = nb_path.stem
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [(f"<!-- executed by `python docs/generate.py` on {machine()}, {stamp}"
             f"{' (FL_DESIGN_QUICK=1)' if quick else ''} -->"), ""]
    n_fig = 0
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            lines += [cell.source, ""]
            continue
        if cell.cell_type != "code" or not cell.source.strip():
            continue
        lines += ["```python", cell.source, "```", ""]
        for out in cell.get("outputs", []):
            data = out.get("data", {})
            if "image/png" in data:
                n_fig += 1
                name = f"{stem}_{n_fig}.png"
                (gal / name).write_bytes(base64.b64decode(data["image/png"]))
                lines += [f"![figure {n_fig} of {stem}]({name})", ""]
            elif out.get("output_type") == "stream" or "text/plain" in data:
                text = out.get("text") or data.get("text/plain", "")
                if text.strip():
                    lines += ["```text", text.rstrip(), "```", ""]
    page = gal / f"{stem}.md"
    page.write_text("\n".join(lines) + "\n")
    return page


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="claims and benchmarks in quick mode")
    ap.add_argument("--only", nargs="*", default=None, help="script stems to run")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds per command")
    ap.add_argument("--table", action="store_true",
                    help="only rewrite the performance table (targets.md, README) from the "
                         "benchmarks' last records; run nothing")
    a = ap.parse_args(argv)
    if a.table:
        table = targets_table()
        (OUT / "targets.md").write_text(table)
        print(readme_table(table))
        return 0
    OUT.mkdir(parents=True, exist_ok=True)
    quick = ["--quick"] if a.quick else []
    jobs = [("snippet", p, []) for p in sorted((ROOT / "docs" / "snippets").glob("*.py"))]
    jobs += [("claim", p, quick) for p in sorted((ROOT / "verify").glob("claim_*.py"))]
    jobs += [("bench", ROOT / "verify" / f"{b}.py", BENCH_ARGS.get(b, []) + quick) for b in BENCHES
             if (ROOT / "verify" / f"{b}.py").exists()]
    for nb in sorted((ROOT / "examples").glob("*.ipynb")):
        if a.only and nb.stem not in a.only:
            continue
        try:
            print(f"wrote {notebook_page(nb, a.quick, a.timeout).relative_to(ROOT)}", flush=True)
        except Exception as exc:  # noqa: BLE001 - a failed notebook is reported, not hidden
            print(f"notebook {nb.name} failed: {type(exc).__name__}: {exc}", file=sys.stderr)
            return 1
    for kind, script, args in jobs:
        if a.only and script.stem not in a.only:
            continue
        path = run(kind, script, args, a.timeout)
        print(f"wrote {path.relative_to(ROOT)}", flush=True)
    write_indexes()
    table = targets_table()
    (OUT / "targets.md").write_text(table)
    if not a.quick:  # quick runs judge no target: the README keeps the full runs' numbers
        print(readme_table(table))
    return 0


def _records() -> list[dict]:
    """Every target record under :data:`TARGETS` (JSON lines; a line that does not parse or
    lacks a field is skipped with a message, never evaluated)."""
    import json

    keys = {"script", "name", "value", "limit", "unit", "relation", "met", "checked", "cpu",
            "isa", "cores", "load", "utc"}
    out = []
    for path in sorted(TARGETS.glob("*.jsonl")) if TARGETS.is_dir() else []:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            try:
                rec = json.loads(line)
            except ValueError:
                rec = None
            if not isinstance(rec, dict) or not keys <= rec.keys():
                print(f"{path.name}:{n}: not a target record, skipped", file=sys.stderr)
                continue
            out.append(rec)
    return out


def _num(value: float, unit: str) -> str:
    text = f"{value:,.0f}" if abs(value) >= 1000 else f"{value:.3g}"
    return f"{text}x" if unit == "x" else f"{text} {unit}"


def _cell(text: str) -> str:
    """Text for a Markdown table cell (a ``|`` in it would end the cell)."""
    return str(text).replace("|", "\\|")


def targets_table() -> str:
    """The performance targets as a Markdown table: what, measured, target, verdict, where
    (the machine once above the table when every row shares it)."""
    recs = _records()
    if not recs:
        return "No benchmark has recorded a target yet: run `make docs-data`.\n"
    machines = {(r["cpu"], r["cores"], r["isa"]) for r in recs}
    shared = len(machines) == 1
    head = []
    if shared:
        cpu, cores, isa = machines.pop()
        head = [f"Measured on {_cell(cpu)}, {cores} cores, kernel ISA {isa}.", ""]
    title = ("| target | measured | limit | verdict | script, "
             f"{'' if shared else 'machine, '}load, date (UTC) |")
    rows = [title, "| --- | --- | --- | --- | --- |"]
    for r in recs:
        verdict = ("met" if r["met"] else "**missed**") if r["checked"] else "not checked"
        what = r["name"] + (f" ({r['detail']})" if r.get("detail") else "")
        where = "" if shared else f"{r['cpu']}, {r['cores']} cores, {r['isa']}, "
        rows.append(f"| {_cell(what)} | {_num(r['value'], r['unit'])} | {r['relation']} "
                    f"{_num(r['limit'], r['unit'])} | {verdict} | `{r['script']}`, "
                    f"{_cell(where)}load {r['load']:.1f}, {r['utc']} |")
    return "\n".join(head + rows) + "\n"


def readme_table(table: str) -> str:
    """Put ``table`` between the README's two marker lines; what it did, as a sentence."""
    readme = ROOT / "README.md"
    text = readme.read_text(encoding="utf-8")
    if text.count(README_BEGIN) != 1 or text.count(README_END) != 1:
        return "README.md: no single pair of performance-table markers, left as it was"
    head, rest = text.split(README_BEGIN)
    _, tail = rest.split(README_END)
    readme.write_text(f"{head}{README_BEGIN}\n{table}{README_END}{tail}", encoding="utf-8")
    return "wrote the performance table in README.md"


def write_indexes() -> None:
    """``claim_index.md`` and ``bench_index.md``: one section per output file present (included
    by ``claims.md`` and ``performance.md`` in ``docs/``, so the paths are relative to it)."""
    for kind, title in (("claim", "claim"), ("bench", "benchmark")):
        parts = []
        for path in sorted(OUT.glob(f"{kind}_*.txt")):
            first = path.read_text().splitlines()[0] if path.stat().st_size else ""
            script = path.stem[len(kind) + 1:]
            doc = ""
            src = ROOT / "verify" / f"{script}.py"
            if src.exists():
                import ast

                doc = (ast.get_docstring(ast.parse(src.read_text())) or "").split("\n\n")[0]
            parts += [f"## `{script}`", "", doc.replace("\n", " "), "",
                      f"```{{literalinclude}} _generated/{path.name}", ":language: text", ":lines: 2-", "```",
                      "", f"*{first.lstrip('# ')}*", ""]
        (OUT / f"{kind}_index.md").write_text(
            "\n".join(parts) if parts else f"No {title} output yet: run `make docs-data`.\n")


if __name__ == "__main__":
    sys.exit(main())
