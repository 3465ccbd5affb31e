"""Held-out variants of issue 36's six classes (used by ``verify/fault_matrix.py``).

Different payloads from ``fault_cases_issue36.py`` and the tests: cache folders re-signed or
planted another way, links and markers in output folders, concurrent writers, markup and
newlines in every user-named field checked in every output format, unbounded expressions and
waits, structural diagnoses, odd environments. Each case is ``(name, code, kind, env, quick,
expect)``; the code runs after the matrix's prelude and :data:`HELPERS`. A case that ends in
a wrong result raises ``AssertionError`` (classified ``raw``: a bug).
"""

from __future__ import annotations

#: Helpers of the held-out cases (run after the matrix's prelude).
HELPERS = r'''
import re, subprocess, csv as _csv

def pend(name="pendulum", y="theta", w="omega", yu="rad", uu="N m", extra="", design=True):
    """A pendulum config whose user-named fields carry the payloads."""
    q = json.dumps
    text = (f"[plant]\nname = {q(name)}\nstates = [{q(y)}, {q(w)}]\ninput = \"u\"\n"
            f"rhs = [{q(w)}, {q(f'-9.81*sin({y}) - 0.5*{w} + u')}]\noutput = {q(y)}\n"
            f"region = {{ {q(y)} = [-3.0, 3.0], {q(w)} = [-10.0, 10.0] }}\n"
            f"input_range = [-20.0, 20.0]\noutput_unit = {q(yu)}\ninput_unit = {q(uu)}\n")
    if design:
        text += ("[design]\nestimator = \"ehgo\"\neps = 0.02\nT = 0.001\n"
                 "coeffs = [3.0, 3.0, 1.0]\ngains = [2.0, 4.0]\ngamma = 0.01\n")
    return toml(text + "[scenario]\nreference = 0.1\n" + extra)

def fences(text):
    """Lines outside Markdown code fences (CommonMark: a fence closes on a line of at least as
    many backticks and nothing else); fails when a fence is left open."""
    out, fence = [], None
    for line in text.splitlines():
        m = re.match(r" {0,3}(`{3,})(.*)$", line)
        if fence is None:
            if m:
                fence = len(m.group(1))
            else:
                out.append(line)
        elif m and len(m.group(1)) >= fence and not m.group(2).strip():
            fence = None
    assert fence is None, "a code fence of report.md is left open (a name opened one)"
    return out

def check_outputs(folder):
    """Every output format of a run escapes what the user named (no markup, no new block)."""
    folder = Path(folder)
    md = (folder / "report.md").read_text(encoding="utf-8")
    for line in fences(md):
        raw = re.search(r"(?<!\\)<(img|svg|b>|script|/script|!--|/pre)", line)
        assert raw is None, f"raw markup in report.md: {line[:200]!r}"
        assert not re.match(r"\s*#+\s*pwn", line), f"a name added a heading: {line[:120]!r}"
        assert not re.match(r"\s*\[pwn\]:", line), f"a name added a link definition: {line!r}"
    html = (folder / "report.html").read_text(encoding="utf-8")
    for m in ("<img src=x", "<b>N", "<svg onload", "<script>alert"):
        assert m not in html, f"raw {m!r} in report.html"
    json.loads((folder / "summary.json").read_text(encoding="utf-8"),
               parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
    for f in sorted((folder / "runs").glob("*.csv")) if (folder / "runs").is_dir() else []:
        with open(f, newline="", encoding="utf-8") as fh:
            rows = _csv.reader(fh)
            head, first = next(rows), next(rows)
            assert len(head) == len(first), f"{f.name}: header of {len(head)} for {len(first)}"
    for f in list((folder / "c").rglob("*")) if (folder / "c").is_dir() else []:
        if f.is_file() and f.suffix in (".c", ".h", "") and not f.name.startswith("."):
            text = f.read_text(encoding="utf-8", errors="replace")
            assert "pwn" not in text and "onerror" not in text, f"a user string in {f.name}"

def run_quick(cfg, out="o", *more):
    rc = cli("run", cfg, "--quick", "--no-progress", "--out", TMP / out, *more)
    assert rc == 0, f"exit {rc}"
    return TMP / out

def proc(args, timeout=100, **env):
    """The CLI in a child; exit 2 (one line) is a clear error, a traceback is raw."""
    p = subprocess.run([sys.executable, "-m", "fl_design", *map(str, args)],
                       capture_output=True, text=True, timeout=timeout,
                       env=dict(os.environ, **env))
    if "Traceback" in p.stderr or p.returncode not in (0, 2):
        raise RuntimeError(f"exit {p.returncode}: {p.stderr[-800:]}")
    if p.returncode == 2:
        raise fl.errors.FlDesignError(p.stderr.strip()[-300:])
    return p
'''

_RESIGN_SWAP = r'''
# two valid entries of this user swapped: each is signed for its own name, never the other's
fl.plants.pendulum().normal_form(); fl.plants.trms_yaw().normal_form()
cache = TMP / 'cache'
a, b = sorted(cache.glob('plant_*.pkl'))[:2]
da, db = a.read_bytes(), b.read_bytes()
ja, jb = Path(str(a) + '.json').read_text(), Path(str(b) + '.json').read_text()
a.write_bytes(db); b.write_bytes(da)
Path(str(a) + '.json').write_text(jb); Path(str(b) + '.json').write_text(ja)
nf = fl.plants.pendulum().normal_form()
assert 'sin' in str(nf.a) or 'sin' in str(getattr(nf, 'alpha', nf)), nf
'''

#: A library whose constructor writes the payload's marker, built as ``TMP/evil.so``.
_EVIL = r'''
import hashlib, hmac, shutil, subprocess
if shutil.which('cc') is None:
    raise ApiMissing('a C compiler')
lib = prebuilt(TMP / 'cache')
(TMP / 'evil.c').write_text('#include <stdio.h>\n__attribute__((constructor)) static void '
                            'boom(void) { FILE *f = fopen("%s", "w"); if (f) fclose(f); }\n'
                            % PWNED)
subprocess.run(['cc', '-shared', '-fPIC', '-o', str(TMP / 'evil.so'), str(TMP / 'evil.c')],
               check=True, timeout=120)
'''

# a kernel whose sidecar is signed with guessed keys: must be rebuilt, not loaded
_KEY_GUESS = _EVIL + r'''
shutil.copy(TMP / 'evil.so', lib)
data = lib.read_bytes()
rec = {'size': len(data), 'sha256': hashlib.sha256(data).hexdigest()}
for key in (b'\0' * 32, b'', b'fl_design'):
    text = f"fl_design cache entry 2\0{lib.name}\0{rec['size']}\0{rec['sha256']}"
    rec['mac'] = hmac.new(key, text.encode(), hashlib.sha256).hexdigest()
    Path(str(lib) + '.json').write_text(json.dumps(rec))
    kernel(TMP / 'cache')
'''

# the kernel's path is a symlink to a library elsewhere (with the real sidecar kept)
_SO_LINK = _EVIL + r'''
lib.unlink(); lib.symlink_to(TMP / 'evil.so')
kernel(TMP / 'cache')
'''

_KEY_FIFO = r'''
from fl_design._cache import key_path
k = key_path(); k.parent.mkdir(parents=True, exist_ok=True, mode=0o700); os.mkfifo(k, 0o600)
fl.plants.pendulum().normal_form()
'''

_KEY_LINK = r'''
# the user's key is a symlink to a file someone else can read: not used
from fl_design._cache import key_path
k = key_path(); k.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
(TMP / 'shared.key').write_bytes(b'k' * 32); os.chmod(TMP / 'shared.key', 0o644)
k.symlink_to(TMP / 'shared.key')
fl.plants.pendulum().normal_form()
'''

_SIDE_JUNK = r'''
fl.plants.pendulum().normal_form()
for side in (TMP / 'cache').glob('*.json'):
    side.write_text(SIDE)
fl.plants.pendulum().normal_form()
'''

_MARKER_HASHED = r'''
# a marker listing the user's files with their true hashes, unsigned: trusted for nothing
import hashlib
files = {n: hashlib.sha256((PROJECT / n).read_bytes()).hexdigest()
         for n in ('Makefile', 'README.md', 'main.c')}
(PROJECT / '.fl_design_output.json').write_text(json.dumps(
    {'format': 'fl_design output 2', 'files': files, 'mac': '0' * 64}))
fl.generate_c(fl.presets.pendulum_design(), PROJECT)
'''

_MARKER_COPIED = r'''
# a marker copied from a folder we wrote into the user's project (signed for another folder)
d = fl.presets.pendulum_design()
fl.generate_c(d, TMP / 'c')
import shutil
shutil.copy(TMP / 'c' / '.fl_design_output.json', PROJECT / '.fl_design_output.json')
for name in ('Makefile',):
    pass
fl.generate_c(d, PROJECT)
'''

_CONCURRENT_CODEGEN = r'''
import subprocess
# two codegen processes into one folder at once: one writes, the other fails clearly
import time
cmd = [sys.executable, '-c', "import sys, fl_design as fl; from fl_design import presets; "
       "fl.generate_c(presets.pendulum_design(), sys.argv[1])", str(TMP / 'c')]
ps = [subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True) for _ in range(3)]
errs = [p.communicate(timeout=100)[1] for p in ps]
codes = [p.returncode for p in ps]
assert 0 in codes, (codes, errs)
for c, e in zip(codes, errs):
    assert c == 0 or 'OutputPathError' in e or 'OutputExistsError' in e or 'another' in e \
        or 'lock' in e, e[-600:]
assert all('Traceback' not in e or 'fl_design.errors' in e for e in errs), errs
if any(codes):
    raise fl.errors.OutputPathError('a concurrent writer was refused')
'''

_STALE_LOCK = r'''
# a lock file left by a killed run (no process holds it): the next run proceeds
d = fl.presets.pendulum_design()
fl.generate_c(d, TMP / 'c')
(TMP / 'c' / '.fl_design_output.lock').write_text('12345')
fl.generate_c(d, TMP / 'c')
'''

_LINK_RUNS = r'''
# out/runs a link to the user's project, no --force: refused, nothing written through
out = run_quick(pend())
import shutil
shutil.rmtree(out / 'runs'); (out / 'runs').symlink_to(PROJECT, target_is_directory=True)
cli('run', pend(), '--quick', '--no-progress', '--out', out)
'''

_LINK_SUMMARY_FORCE = r'''
# with --force a symlinked summary.json is replaced by a file, never written through
out = run_quick(pend())
(out / 'summary.json').unlink(); (out / 'summary.json').symlink_to(VICTIM)
run_quick(pend(), 'o', '--force')
assert not (out / 'summary.json').is_symlink()
'''

_OUT_IS_LINK = r'''
# --out names a link to the user's project
(TMP / 'o').symlink_to(PROJECT, target_is_directory=True)
cli('run', pend(), '--quick', '--no-progress', '--out', TMP / 'o')
'''

_DANGLING = r'''
# a dangling link at c/fl.h pointing where a new file would be created outside
d = fl.presets.pendulum_design()
fl.generate_c(d, TMP / 'c')
h = next((TMP / 'c').glob('*.h')); h.unlink(); h.symlink_to(TMP / 'created_outside.h')
try:
    fl.generate_c(d, TMP / 'c')
finally:
    assert not (TMP / 'created_outside.h').exists(), 'written through a dangling link'
'''


def _markup(field: str, payload: str) -> str:
    return (f"out = run_quick(pend({field}={payload!r}))\ncheck_outputs(out)\n")


def _unbounded(expr: str) -> str:
    return f"cli('derive', custom({expr!r}))"


_SILENT_BYTES = r'''
# a server that answers garbage at once, or closes at once: a clear error in bounded time
import socket, threading, time
srv = socket.socket(); srv.bind(('127.0.0.1', 0)); srv.listen(8)
def serve():
    while True:
        c, _ = srv.accept()
        if MODE == 'garbage':
            c.sendall(b'HTTP/1.0 200 OK\r\n\r\n' + b'\xff' * 4096)
        c.close()
threading.Thread(target=serve, daemon=True).start()
from fl_design.sim._executor import connect_scheduler
start = time.monotonic()
try:
    connect_scheduler('tcp://127.0.0.1:' + str(srv.getsockname()[1]), timeout=3.0)
finally:
    assert time.monotonic() - start < 30, 'not bounded'
'''

_SHORT_RUN = r'''
resp = simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, DUR))
label = getattr(resp.status, 'label', resp.status)
assert label in ('undecided', 'converging', 'converged'), (label, getattr(resp, 'status_reason', ''))
'''

_STDERR_CLOSED = r'''
p = pend(name='Pendel \u03b8')
r = subprocess.run(f'"{sys.executable}" -m fl_design derive "{p}" 2>&- >/dev/null', shell=True,
                   capture_output=True, text=True, timeout=100)
assert r.returncode in (0, 2), r
'''

_PIPE_HEAD = r'''
p = pend()
r = subprocess.run(f'"{sys.executable}" -m fl_design derive "{p}" | head -c 10', shell=True,
                   capture_output=True, text=True, timeout=100)
assert 'Traceback' not in r.stderr, r.stderr[-800:]
'''


def cases() -> list[tuple]:
    """The held-out cases: ``(name, code, kind, env, quick, expect)``."""
    cache = {"FL_DESIGN_CACHE": "@TMP@/cache"}
    h = HELPERS
    out = [
        # 1. a cache from someone else, or re-signed
        ("held-out cache: two valid entries swapped", _RESIGN_SWAP, "env", cache, True,
         "result"),
        ("held-out cache: kernel sidecar signed with guessed keys", _KEY_GUESS, "env", cache,
         False, "result"),
        ("held-out cache: kernel path a symlink to a library elsewhere", _SO_LINK, "env", cache,
         False, "result"),
        ("held-out cache: key file a FIFO", _KEY_FIFO, "env", cache, False, None),
        ("held-out cache: key a symlink to a shared file", _KEY_LINK, "env", cache, False,
         None),
        ("held-out cache: sidecars not JSON", _SIDE_JUNK.replace("SIDE", "'{{{'"), "env",
         cache, False, "result"),
        ("held-out cache: sidecars with a negative size",
         _SIDE_JUNK.replace("SIDE", "json.dumps({'size': -1, 'sha256': 'x', 'mac': 'y'})"),
         "env", cache, False, "result"),
        ("held-out cache: FL_DESIGN_CACHE a link to a world-writable folder",
         ("(TMP / 'ww').mkdir(); os.chmod(TMP / 'ww', 0o777)\n"
         "(TMP / 'cache').symlink_to(TMP / 'ww')\nfl.plants.pendulum().normal_form()"), "env",
         cache, False, None),
        # 2. output folders
        ("held-out output: unsigned marker with the user's true hashes", _MARKER_HASHED, "env",
         {}, True, "error"),
        ("held-out output: a marker copied from another folder", _MARKER_COPIED, "env", {},
         False, "error"),
        ("held-out output: three concurrent codegen processes", _CONCURRENT_CODEGEN, "env", {},
         False, None),
        ("held-out output: a stale lock file", _STALE_LOCK, "env", {}, False, "result"),
        ("held-out output: runs/ a link to the project", h + _LINK_RUNS, "env", {}, False,
         "error"),
        ("held-out output: --force with a symlinked summary.json", h + _LINK_SUMMARY_FORCE,
         "env", {}, False, "result"),
        ("held-out output: --out a link to the project", h + _OUT_IS_LINK, "env", {}, False,
         "error"),
        ("held-out output: a dangling link at the header", _DANGLING, "env", {}, False, None),
        ("held-out output: --out is a regular file",
         h + "cli('run', pend(), '--quick', '--out', a_file())", "env", {}, False, "error"),
        # 3. markup, newlines and mathtext in every user-named field, every format
        ("held-out markup: a name closing the report's code fence",
         h + _markup("name", "x\n```\n<img src=x onerror=alert(1)>\n# pwn\n```"), "input", {},
         True, None),
        ("held-out markup: a name with a link definition and CR",
         h + _markup("name", "a\r\n[pwn]: javascript:alert(1)\r\n| c | d |"), "input", {},
         False, None),
        ("held-out markup: an output unit with HTML and a heading",
         h + _markup("yu", "<svg onload=alert(1)>\n# pwn"), "input", {}, False, None),
        ("held-out markup: an input unit with mathtext and a fence",
         h + _markup("uu", "$\\frac{$ ```"), "input", {}, False, None),
        ("held-out markup: a unit of unbalanced mathtext braces",
         h + _markup("yu", "$x^{2$"), "input", {}, False, None),
        ("held-out markup: a unit of only dollars", h + _markup("yu", "$$"), "input", {},
         False, None),
        ("held-out markup: a name with a terminal escape sequence",
         h + _markup("name", "p\x1b]0;pwn\x07\x1b[2J") + "r = proc(['derive', pend(name="
         "'p\\x1b]0;pwn\\x07\\x1b[2J')])\nassert '\\x1b' not in r.stdout + r.stderr, "
         "'a terminal escape reached the terminal'\n", "input", {}, False, None),
        ("held-out markup: a name closing a C comment",
         h + _markup("name", "*/ int pwn = 1; /*"), "input", {}, False, None),
        ("held-out markup: a name with </script> and <!--",
         h + _markup("name", "</script><script>alert(1)</script><!--"), "input", {}, False,
         None),
        ("held-out markup: state names with Greek letters",
         h + _markup("y", "\u03b8") .replace("pend(y=", "pend(w='\u03c9', y="), "input", {},
         False, None),
        ("held-out markup: a state name with markup",
         h + "cli('derive', pend(y='x<b>'))", "input", {}, False, "error"),
        ("held-out markup: a 100 000-character plant name",
         h + "run_quick(pend(name='n' * 100_000))", "input", {}, False, None),
        ("held-out markup: a name with a NUL character",
         h + _markup("name", "a\x00b"), "input", {}, False, None),
        # 4. unbounded expressions and waits
        ("held-out bounds: 2**2**2**2**2**2 * x1 + u", _unbounded("2**2**2**2**2**2 * x1 + u"),
         "input", {}, True, "error"),
        ("held-out bounds: 9**9**9 + u", _unbounded("9**9**9 + u"), "input", {}, False,
         "error"),
        ("held-out bounds: (x1 + x2)**(10**6) + u", _unbounded("(x1 + x2)**(10**6) + u"),
         "input", {}, False, "error"),
        ("held-out bounds: x1**2**2**2**2 + u", _unbounded("x1**2**2**2**2 + u"), "input", {},
         False, "error"),
        ("held-out bounds: exp nested 12 deep", _unbounded("exp(" * 12 + "x1" + ")" * 12
                                                          + " + u"), "input", {}, False, None),
        ("held-out bounds: (x1 + x2 + u)**64 * (x1 - x2)**64", _unbounded(
            "(x1 + x2 + u)**64 * (x1 - x2)**64 - x1"), "input", {}, False, None),
        ("held-out bounds: 1e308 * 1e308 * x1 + u", _unbounded("1e308 * 1e308 * x1 + u"),
         "input", {}, False, "error"),
        ("held-out waits: a scheduler that answers garbage",
         _SILENT_BYTES.replace("MODE", "'garbage'"), "env", {}, False, "error"),
        ("held-out waits: a scheduler that closes at once",
         _SILENT_BYTES.replace("MODE", "'close'"), "env", {}, False, "error"),
        ("held-out waits: --scheduler with no port", h + "proc(['run', pend(), '--quick', "
         "'--out', TMP / 'o', '--scheduler', 'tcp://127.0.0.1'])", "env", {}, False, "error"),
        ("held-out waits: --scheduler on a closed port", h + "proc(['sweep', pend(), '--quick',"
         " '--scheduler', 'tcp://127.0.0.1:9'])", "env", {}, False, "error"),
        # 5. structural diagnoses
        ("held-out structure: -x1 + 2*u + u**3 has rho 1",
         ("assert fl.Plant.from_ode([x1], u, ['-x1 + 2*u + u**3'], x1, input_range=(-3, 3))"
         ".relative_degree() == 1"), "input", {}, True, "result"),
        ("held-out structure: -x1 + (2 + cos(u))*u has rho 1",
         ("assert fl.Plant.from_ode([x1], u, ['-x1 + (2 + cos(x1))*u'], x1, input_range=(-3, 3))"
         ".relative_degree() == 1"), "input", {}, False, "result"),
        ("held-out structure: b = 1 + 60 u**59 via derive",
         ("cli('derive', toml('[plant]\\nstates = [\"x1\"]\\ninput = \"u\"\\nrhs = [\"-x1 + u + "
         "u**60\"]\\noutput = \"x1\"\\ninput_range = [-1.5, 1.5]\\n'))"), "input", {}, False,
         "result"),
        ("held-out structure: fi and the ligature fi", h + "cli('derive', pend(y='fi', "
         "w='\\ufb01'))", "input", {}, True, "error"),
        ("held-out structure: x1 and the subscript x\u2081",
         ("fl.Plant.from_ode([x1, sp.Symbol('x\u2081', real=True)], u, "
         "[sp.Symbol('x\u2081', real=True), u], x1)"), "input", {}, False, "error"),
        ("held-out structure: omega and the Ohm sign", h + "cli('derive', pend(y='th', "
         "w='\\u2126'))", "input", {}, False, None),
        ("held-out structure: fullwidth x1 and x1",
         ("cli('derive', toml('[plant]\\nstates = [\"x1\", \"\\uff581\"]\\ninput = \"u\"\\n"
         "rhs = [\"\\uff581\", \"u\"]\\noutput = \"x1\"\\n'))"), "input", {}, False, "error"),
        ("held-out structure: a state named I", ("cli('derive', toml('[plant]\\nstates = [\"I\","
         " \"x2\"]\\ninput = \"u\"\\nrhs = [\"x2\", \"-I + u\"]\\noutput = \"I\"\\n'))"), "input",
         {}, False, None),
        ("held-out structure: a state named exp", ("cli('derive', toml('[plant]\\nstates = "
         "[\"exp\", \"x2\"]\\ninput = \"u\"\\nrhs = [\"x2\", \"-exp + u\"]\\noutput = \"exp\"\\n'))"),
         "input", {}, False, "error"),
        ("held-out structure: a state named lambda", ("cli('derive', toml('[plant]\\nstates = "
         "[\"lambda\", \"x2\"]\\ninput = \"u\"\\nrhs = [\"x2\", \"u\"]\\noutput = \"lambda\"\\n'))"),
         "input", {}, False, "error"),
        ("held-out structure: a 0.05 s run is undecided", _SHORT_RUN.replace("DUR", "0.05"),
         "input", {}, True, "result"),
        ("held-out structure: a 0.5 s run is not stalled", _SHORT_RUN.replace("DUR", "0.5"),
         "input", {}, False, "result"),
        # 6. raw tracebacks from odd environments
        ("held-out raw: stderr closed and stdout discarded", h + _STDERR_CLOSED, "env", {},
         False, None),
        ("held-out raw: stdout through head -c 10", h + _PIPE_HEAD, "env", {}, False, None),
        ("held-out raw: latin-1 stdout, a CJK plant name",
         h + "proc(['derive', pend(name='\u5012\u7acb\u632f\u5b50')], "
         "PYTHONIOENCODING='latin-1')", "env", {}, False, None),
        ("held-out raw: HOME unset, no XDG_CONFIG_HOME",
         ("os.environ.pop('HOME', None); os.environ.pop('XDG_CONFIG_HOME', None)\n"
         "fl.plants.pendulum().normal_form()"), "env", cache, False, None),
        ("held-out raw: TMPDIR does not exist", h + "proc(['derive', pend()], "
         "TMPDIR=str(TMP / 'nowhere'))", "env", {}, False, None),
        ("held-out raw: MPLCONFIGDIR a file", h + "run_quick(pend(), 'o')\n", "env",
         {"MPLCONFIGDIR": "@TMP@/f"}, False, "result"),
        ("held-out raw: a plant name that is a number", h + "cli('derive', toml("
         "'[plant]\\nname = 42\\nstates = [\"x1\"]\\ninput = \"u\"\\nrhs = [\"-x1 + u\"]\\n"
         "output = \"x1\"\\n'))", "input", {}, False, "error"),
        ("held-out raw: a 5000-term SymPy sum", ("e = sp.Add(*[sp.Symbol(f'k{i}') * x1 for i in "
         "range(5000)], evaluate=False)\nfl.Plant.from_ode([x1, x2], u, [x2, e + u], x1)"),
         "input", {}, False, "error"),
        ("held-out raw: a SymPy Matrix as the rhs", ("fl.Plant.from_ode([x1, x2], u, "
         "sp.Matrix([x2, u]), x1).relative_degree()"), "input", {}, False, None),
    ]
    return out + more_cases() + third_cases()


_DEEP_TOML = r"""
p = TMP / 'deep.toml'
p.write_text('[plant]\nlibrary = "pendulum"\n[sweep]\neps = ' + '[' * 5000 + ']' * 5000 + '\n')
cli('derive', p)
"""

_ENTRY_LINK = r"""
# a cache entry replaced by a link to a copy elsewhere (same bytes, same sidecar): not followed
fl.plants.pendulum().normal_form()
cache = TMP / 'cache'
f = sorted(cache.glob('plant_*.pkl'))[0]
(TMP / 'elsewhere.pkl').write_bytes(f.read_bytes())
f.unlink(); f.symlink_to(TMP / 'elsewhere.pkl')
nf = fl.plants.pendulum().normal_form()
assert nf.rho == 2
"""

_SHORT_STATES = r"""
# states named like the loop's own quantities, through simulate and C code
import sympy as sp
T, gamma, r = sp.symbols('T gamma r', real=True)
p = fl.Plant.from_ode([T, gamma], u, [gamma, -T - gamma + u], T)
resp = simulate(p, design(), fl.Scenario(0.1, 2.0))
assert abs(resp.y[-1] - 0.1) < 0.05, resp.y[-1]
fl.generate_c(design(), TMP / 'c')
"""


def more_cases() -> list[tuple]:
    """A second batch of held-out variants."""
    cache = {"FL_DESIGN_CACHE": "@TMP@/cache"}
    h = HELPERS
    ok = "result"
    return [
        ("held-out cache: an entry replaced by a link to a copy", _ENTRY_LINK, "env", cache,
         False, ok),
        ("held-out cache: an entry truncated to 0 bytes",
         ("fl.plants.pendulum().normal_form()\n"
         "[f.write_bytes(b'') for f in (TMP / 'cache').glob('plant_*.pkl')]\n"
         "assert fl.plants.pendulum().normal_form().rho == 2"), "env", cache, False, ok),
        ("held-out output: report.md is a directory",
         h + "(TMP / 'o').mkdir(); (TMP / 'o' / 'report.md').mkdir()\n"
         "cli('run', pend(), '--quick', '--no-progress', '--out', TMP / 'o')", "env", {},
         False, "error"),
        ("held-out output: the marker is a directory",
         ("(TMP / 'c').mkdir(); (TMP / 'c' / '.fl_design_output.json').mkdir()\n"
         "fl.generate_c(fl.presets.pendulum_design(), TMP / 'c')"), "env", {}, False, "error"),
        ("held-out output: c/build a FIFO",
         ("d = fl.presets.pendulum_design(); fl.generate_c(d, TMP / 'c')\n"
         "import shutil; shutil.rmtree(TMP / 'c' / 'build', ignore_errors=True)\n"
         "os.mkfifo(TMP / 'c' / 'build')\nfl.generate_c(d, TMP / 'c')"), "env", {}, False,
         "error"),
        ("held-out raw: a config that is a directory",
         "(TMP / 'cfg.toml').mkdir()\ncli('derive', TMP / 'cfg.toml')", "input", {}, False,
         "error"),
        ("held-out raw: a config in Latin-1", ("p = TMP / 'l1.toml'\n"
         "p.write_bytes('[plant]\\nname = \"Pendel \\xe4\"\\nlibrary = \"pendulum\"\\n'"
         ".encode('latin-1'))\ncli('derive', p)"), "input", {}, False, "error"),
        ("held-out raw: a TOML array nested 5000 deep", _DEEP_TOML, "input", {}, False,
         "error"),
        ("held-out raw: a 20 MB config", ("p = TMP / 'big.toml'\n"
         "p.write_text('[plant]\\nlibrary = \"pendulum\"\\n# ' + 'x' * 20_000_000 + '\\n')\n"
         "cli('derive', p)"), "input", {}, False, None),
        ("held-out raw: states named T and gamma", _SHORT_STATES, "input", {}, False, ok),
        ("held-out raw: a parameter named pi", ("fl.Plant.from_ode([x1, x2], u, "
         "[x2, '-k*x1 + u'], x1, params={'pi': 2.0, 'k': 1.0})"), "input", {}, False,
         "error"),
        ("held-out raw: (-1)**x1 in the rhs", "ode('(-1)**x1 + u').relative_degree()",
         "input", {}, False, None),
        ("held-out raw: x1**(1/3) at the operating point 0",
         "ode('-x1**(1/3) + u').relative_degree()", "input", {}, False, None),
        ("held-out bounds: exp(1000*x1) over the region",
         ("fl.Plant.from_ode([x1, x2], u, [x2, '-exp(1000*x1) + 1 + u'], x1, "
         "region={x1: (-1, 1), x2: (-1, 1)}, input_range=(-5, 5)).b_bounds()"), "input", {},
         False, None),
        ("held-out bounds: (x1 + x2 + x1*x2 + u)**30",
         "ode('(x1 + x2 + x1*x2 + u)**30 - x1').relative_degree()", "input", {}, False,
         "error"),
        ("held-out bounds: a 1e9 s scenario", ("simulate(fl.plants.pendulum(), design(), "
         "fl.Scenario(0.1, 1e9))"), "input", {}, False, "error"),
        ("held-out bounds: a sweep of 10**8 points", ("sweep(fl.plants.pendulum(), design(), "
         "fl.Scenario(0.1, 1.0), eps=np.geomspace(1e-3, 1, 10**4), "
         "gamma=np.geomspace(1e-3, 1, 10**4), progress=False)"), "input", {}, False, "error"),
        ("held-out structure: b = -(1 + 3 u**2) has rho 1 and b < 0",
         ("p = fl.Plant.from_ode([x1], u, ['-x1 - u - u**3'], x1, input_range=(-2, 2))\n"
         "assert p.relative_degree() == 1\nlo, hi = p.b_bounds()\nassert hi < 0, (lo, hi)"),
         "input", {}, False, ok),
        ("held-out structure: b = 2 + sin(x1) on a rho-2 plant",
         ("p = fl.Plant.from_ode([x1, x2], u, [x2, '(2 + sin(x1))*u - x1'], x1, region={x1: (-3, "
          "3), x2: (-1, 1)}, input_range=(-5, 5))\nassert p.relative_degree() == 2\n"
         "lo, hi = p.b_bounds()\nassert 1 - 1e-9 <= lo <= hi <= 3 + 1e-9, (lo, hi)"), "input",
         {}, False, ok),
        ("held-out structure: b = x1 - 5 nonzero on the region",
         ("p = fl.Plant.from_ode([x1, x2], u, [x2, '(x1 - 5)*u'], x1, region={x1: (-1, 1), "
         "x2: (-1, 1)})\nassert p.relative_degree() == 2"), "input", {}, False, ok),
        ("held-out structure: b = x1 changing sign on the region",
         ("p = fl.Plant.from_ode([x1, x2], u, [x2, 'x1*u - x2 + 1'], x1, region={x1: (-1, 1), "
         "x2: (-1, 1)}, operating_point={x1: 0.5})\n"
         "simulate(p, design(), fl.Scenario(0.6, 1.0))"), "input", {}, False, None),
    ]


_SHELL_DIR = r"""
# an output folder whose name is shell and make syntax: never run as a command
import shutil
if shutil.which('cc') is None or shutil.which('make') is None:
    raise ApiMissing('a C compiler and make')
out = TMP / ('c $(touch ' + str(PWNED) + ') `touch ' + str(PWNED) + '`; touch ' + str(PWNED))
pkg = fl.generate_c(fl.presets.pendulum_design(), out)
pkg.verify(fl.plants.pendulum(), fl.Scenario(0.1, 0.5))
"""

_INTERNAL_NAMES = r"""
# states named like the pipeline's own symbols
import sympy as sp
xi, q, D = sp.symbols(NAMES, real=True)
p = fl.Plant.from_ode([xi, q], u, [q, -D * 0 - xi - q + u], xi) if False else \
    fl.Plant.from_ode([xi, q], u, [q, -xi - q + u], xi)
resp = simulate(p, design(), fl.Scenario(0.1, 3.0))
assert abs(resp.y[-1] - 0.1) < 0.05, resp.y[-1]
"""


_SWEEP_ON = ("sweep(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.05, 0.3), "
             "eps=[0.01, 0.02, 0.04], gamma=[1e-2, 2e-2], executor=ex, progress=False, "
             "kernel=fl.Kernel(chunk_size=1))\n")


def third_cases() -> list[tuple]:
    """A third batch: C packages, names the pipeline uses itself, format strings."""
    h = HELPERS
    g = "d = fl.presets.pendulum_design()\n"
    return [
        ("held-out output: a folder named with shell and make syntax", _SHELL_DIR, "env", {},
         False, "result"),
        ("held-out output: prefix 'sil'", g + "fl.generate_c(d, TMP / 'c', prefix='sil')",
         "env", {}, False, None),
        ("held-out output: prefix 'Makefile'", g + "fl.generate_c(d, TMP / 'c', "
         "prefix='Makefile')", "env", {}, False, None),
        ("held-out output: prefix with a slash", g + "fl.generate_c(d, TMP / 'c', "
         "prefix='../x')", "env", {}, False, "error"),
        ("held-out output: prefix 'double'", g + "fl.generate_c(d, TMP / 'c', "
         "prefix='double')", "env", {}, False, "error"),
        ("held-out output: prefix of 300 characters", g + "fl.generate_c(d, TMP / 'c', "
         "prefix='p' * 300)", "env", {}, False, None),
        ("held-out output: prefix with a non-ASCII letter", g + "fl.generate_c(d, TMP / 'c', "
         "prefix='\u03c0_loop')", "env", {}, False, "error"),
        ("held-out raw: states named xi and q", _INTERNAL_NAMES.replace("NAMES", "'xi q D'"),
         "input", {}, False, "result"),
        ("held-out raw: states named int and float",
         _INTERNAL_NAMES.replace("NAMES", "'int float D'"), "input", {}, False, None),
        ("held-out markup: a unit with format fields",
         h + _markup("yu", "{0} {__class__} %s %(x)s {{"), "input", {}, False, None),
        ("held-out markup: a name with format fields",
         h + _markup("name", "{} {0!r:>{1}} %s%s%n"), "input", {}, False, None),
        ("held-out waits: a shut-down thread pool", "from concurrent.futures import "
         "ThreadPoolExecutor\nex = ThreadPoolExecutor(2); ex.shutdown()\n" + _SWEEP_ON,
         "env", {}, False, "error"),
        ("held-out waits: a process pool whose workers exit at start",
         "from concurrent.futures import ProcessPoolExecutor\n"
         "ex = ProcessPoolExecutor(1, initializer=os._exit, initargs=(3,))\n" + _SWEEP_ON,
         "env", {}, False, "error"),
        ("held-out waits: a worker killed mid-map keeps a partial map",
         "from concurrent.futures import ProcessPoolExecutor\nimport multiprocessing as mp\n"
         "class Dies(ProcessPoolExecutor):\n    n = 0\n"
         "    def submit(self, fn, *a, **k):\n        Dies.n += 1\n"
         "        return super().submit(*((os._exit, 3) if Dies.n == 2 else (fn, *a)), **k)\n"
         "ex = Dies(1, mp_context=mp.get_context('fork'))\ntry:\n"
         "    " + _SWEEP_ON.strip() + "\nexcept fl.errors.WorkerLostError as err:\n"
         "    assert isinstance(err.partial, fl.StabilityMap) and err.partial.lost.any()\n"
         "    assert (err.partial.labels[err.partial.lost] == 'undecided').all()\n    raise\n",
         "env", {}, True, "error"),
        ("held-out structure: a parameter and a state of one name",
         "fl.Plant.from_ode([x1, x2], u, [x2, '-x1 + u'], x1, params={'x1': 1.0})", "input",
         {}, False, "error"),
    ]


__all__ = ["HELPERS", "cases", "more_cases", "third_cases"]
