"""Fault-matrix cases of issue 36 (used by ``verify/fault_matrix.py``): a cache folder from
someone else, output folders written through, unbounded waits, false structural diagnoses and
raw tracebacks. Each case is ``(name, code, kind, env, quick, expect)``; the code runs after
the matrix's prelude (``TMP``, ``PWNED``, ``VICTIM``, ``PROJECT``, ``cli``, ``toml``...)."""

from __future__ import annotations

#: Re-sign every derivation entry with a key shipped inside the cache folder (the old layout).
_SHIPPED_KEY = r'''
import hashlib, hmac, pickle
class Boom:
    def __reduce__(self):
        return (open, (str(PWNED), 'w'))
fl.plants.trms_yaw().normal_form()
cache = TMP / 'cache'
key = b'k' * 32
(cache / '.fl_design_key').write_bytes(key); os.chmod(cache / '.fl_design_key', 0o600)
for f in cache.glob('plant_*.pkl'):
    payload = pickle.dumps(Boom())
    data = hmac.new(key, f.name.encode() + b'\0' + payload, hashlib.sha256).digest() + payload
    f.write_bytes(data)
    rec = {'size': len(data), 'sha256': hashlib.sha256(data).hexdigest()}
    text = f"fl_design cache entry 2\0{f.name}\0{rec['size']}\0{rec['sha256']}"
    rec['mac'] = hmac.new(key, text.encode(), hashlib.sha256).hexdigest()
    Path(str(f) + '.json').write_text(json.dumps(rec))
fl.plants.trms_yaw().normal_form()
'''

#: A library with a constructor, planted at the kernel's path with a matching sidecar.
_PLANTED_SO = r'''
import hashlib, shutil, subprocess
if shutil.which('cc') is None:
    raise ApiMissing('a C compiler')
lib = prebuilt(TMP / 'cache')
src = TMP / 'evil.c'
src.write_text('#include <stdio.h>\n__attribute__((constructor)) static void boom(void) '
               '{ FILE *f = fopen("%s", "w"); if (f) fclose(f); }\n' % PWNED)
subprocess.run(['cc', '-shared', '-fPIC', '-o', str(lib), str(src)], check=True, timeout=120)
data = lib.read_bytes()
Path(str(lib) + '.json').write_text(json.dumps(
    {'size': len(data), 'sha256': hashlib.sha256(data).hexdigest(), 'mac': '0' * 64}))
kernel(TMP / 'cache')
'''

_COPIED = r'''
fl.plants.pendulum().normal_form()
os.environ['XDG_CONFIG_HOME'] = str(TMP / 'someone_else')
fl.plants.pendulum().normal_form()
'''

_GEN = "from fl_design import presets\nd = presets.least_squares_design(9)\n"


def _regenerate(tamper: str, again: str = "") -> str:
    """Generate a package into ``TMP / 'c'``, run ``tamper`` on it, then generate again
    (``again``: extra arguments of the second ``generate_c``, e.g. ``", force=True"``)."""
    return (_GEN + "fl.generate_c(d, TMP / 'c')\n" + tamper
            + f"\nfl.generate_c(d, TMP / 'c'{again})")

_HOLDER = r'''
import subprocess, time
hold = ("import sys, time\nfrom fl_design._output import claim_output_folder\n"
        "claim_output_folder(sys.argv[1]); print('claimed', flush=True); time.sleep(60)")
p = subprocess.Popen([sys.executable, '-c', hold, str(TMP / 'o')], stdout=subprocess.PIPE, text=True)
try:
    assert p.stdout.readline().strip() == 'claimed'
    from fl_design._output import claim_output_folder
    claim_output_folder(TMP / 'o')
finally:
    p.kill(); p.wait(30)
'''

_SILENT = r'''
import socket, threading
srv = socket.socket(); srv.bind(('127.0.0.1', 0)); srv.listen(4)
held = []
threading.Thread(target=lambda: [held.append(srv.accept()[0]) for _ in range(4)], daemon=True).start()
from fl_design.sim._executor import connect_scheduler
connect_scheduler('SCHEME://127.0.0.1:' + str(srv.getsockname()[1]), timeout=2.0)
'''

_WORKERLESS = r'''
from concurrent.futures import Executor, Future
from fl_design.sim import _executor
_executor.HEARTBEAT_SECONDS, _executor.WORKERLESS_SECONDS = 0.1, 0.5
class C:
    n = 0
    def nthreads(self):
        C.n += 1
        return {'tcp://10.0.0.7:4001': 1} if C.n == 1 else {}
class X(Executor):
    _max_workers = 2
    _client = C()
    def submit(self, fn, /, *a, **k):
        return Future()
sweep(fl.plants.pendulum(), design(), fl.Scenario(0.05, 0.1), eps=[0.01, 0.02],
      gamma=[1e-2, 3e-2], executor=X(), progress=False)
'''

_STREAM = r'''
import subprocess
p = toml('[plant]\nname = "Pendel \u03b8"\nstates = ["th", "om"]\ninput = "u"\n'
         'rhs = ["om", "-9.81*sin(th) + u"]\noutput = "th"\n')
cmd = [sys.executable, '-m', 'fl_design', 'derive', str(p)]
proc = subprocess.run(REDIRECT, shell=True, stderr=subprocess.PIPE, stdout=subprocess.PIPE,
                      text=True, timeout=100, env=dict(os.environ, **ENV))
if 'Traceback' in proc.stderr or proc.returncode not in (0, 2):
    raise RuntimeError(proc.stderr[-800:])
if proc.returncode == 2:
    raise fl.errors.FlDesignError(proc.stderr.strip())
'''


def _stream(redirect: str, env: dict) -> str:
    cmd = "f'\"{sys.executable}\" -m fl_design derive \"{p}\" " + redirect + "'"
    return _STREAM.replace("REDIRECT", cmd).replace("ENV", repr(env))


def cases() -> list[tuple]:
    """The issue-36 cases: ``(name, code, kind, env, quick, expect)``."""
    cache = {"FL_DESIGN_CACHE": "@TMP@/cache"}
    deep = ("e = u\nfor _ in range(500):\n    e = sp.sin(e, evaluate=False)\n"
            "fl.Plant.from_ode([x1, x2], u, [x2, e], x1)")
    out = [
        ("cache: a folder carrying its own key (re-signed pickles)", _SHIPPED_KEY, "env",
         cache, True, "result"),
        ("cache: planted kernel with a constructor and a matching sidecar", _PLANTED_SO, "env",
         cache, False, "result"),
        ("cache: copied from another user", _COPIED, "env", cache, False, "result"),
        ("output: symlink at c/build/sil.c", _regenerate(
            "(TMP / 'c' / 'build').mkdir()\n(TMP / 'c' / 'build' / 'sil.c').symlink_to(VICTIM)"),
         "env", {}, True, "error"),
        ("output: c/build a link to a user folder", _regenerate(
            "(TMP / 'c' / 'build').symlink_to(TMP, target_is_directory=True)"),
         "env", {}, False, "error"),
        ("output: --force with a symlinked Makefile", _regenerate(
            "(TMP / 'c' / 'Makefile').unlink(); (TMP / 'c' / 'Makefile').symlink_to(VICTIM)",
            ", force=True"), "env", {}, False, "result"),
        ("output: a hard link in the folder", _regenerate(
            "(TMP / 'c' / 'fl.c').unlink(); os.link(VICTIM, TMP / 'c' / 'fl.c')"),
         "env", {}, False, "error"),
        ("output: a FIFO named report.html", ("from fl_design._output import claim_output_folder\n"
         "(TMP / 'o').mkdir(); os.mkfifo(TMP / 'o' / 'report.html')\n"
         "claim_output_folder(TMP / 'o')"), "env", {}, False, "error"),
        ("output: planted marker in a project", ("(PROJECT / '.fl_design_output.json').write_text("
         "json.dumps({'format': 'fl_design output 1', 'files': {}}))\n"
         "os.chdir(PROJECT); cli('codegen', '.')"), "env", {}, True, "error"),
        ("output: a second concurrent run", _HOLDER, "env", {}, False, "error"),
        ("output: prefix='main'", _GEN + "fl.generate_c(d, TMP / 'c', prefix='main')", "env", {},
         False, "error"),
        ("bounds: (x1 + x2 + u)**1000 - x1", "ode('(x1 + x2 + u)**1000 - x1').relative_degree()",
         "input", {}, True, "error"),
        ("bounds: derive (x1 + x2 + u)**1000 - x1",
         "cli('derive', custom('(x1 + x2 + u)**1000 - x1'))", "input", {}, False, "error"),
        ("bounds: a derivation past FL_DESIGN_DERIVE_SECONDS",
         "ode('(x1 + x2 + u)**40 - x1').normal_form()", "env",
         {"FL_DESIGN_DERIVE_SECONDS": "0.05"}, False, "error"),
        ("bounds: a 500-deep SymPy expression", deep, "input", {}, False, "error"),
        ("waits: a scheduler that accepts and never answers", _SILENT.replace("SCHEME", "tcp"),
         "env", {}, False, "error"),
        ("waits: tls:// scheduler without certificates", _SILENT.replace("SCHEME", "tls"),
         "env", {}, False, "error"),
        ("waits: a Dask cluster whose workers all die", _WORKERLESS, "env", {}, False, "error"),
        ("structure: -x1 + u + u**40 on input_range (-2, 2)",
         ("assert fl.Plant.from_ode([x1], u, ['-x1 + u + u**40'], x1, input_range=(-2, 2))"
          ".relative_degree() == 1"), "input", {}, True, "result"),
        ("structure: states h and the Planck-constant h",
         ("cli('derive', toml('[plant]\\nstates = [\"h\", \"\\u210e\"]\\ninput = \"u\"\\n"
          "rhs = [\"\\u210e\", \"u\"]\\noutput = \"h\"\\n'))"), "input", {}, True, "error"),
        ("structure: a state named sin", ("cli('derive', toml('[plant]\\nstates = [\"sin\", "
         "\"x2\"]\\ninput = \"u\"\\nrhs = [\"x2\", \"u\"]\\noutput = \"sin\"\\n'))"), "input",
         {}, False, "error"),
        ("raw: stdout closed", _stream(">&-", {}), "env", {}, True, "error"),
        ("raw: stdout full", _stream("> /dev/full", {}), "env", {}, False, "error"),
        ("raw: ASCII-only stdout, non-ASCII plant name",
         _stream("", {"PYTHONIOENCODING": "ascii"}), "env", {}, False, "result"),
    ]
    return out


__all__ = ["cases"]
