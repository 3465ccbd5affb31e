"""The firmware team: the C package of the paper's design, checked software-in-the-loop."""
import tempfile

import fl_design as fl

design = fl.presets.paper_design()                  # the paper's TRMS design, T = 1 ms
out = tempfile.mkdtemp(prefix="fl_c_")
pkg = fl.generate_c(design, out, precision="double")
res = pkg.verify(fl.plants.trms_yaw(), fl.Scenario(0.3, 30.0))
print("SIL passed:", res.passed)
print(sorted(p.name for p in pkg.files)[:8] if hasattr(pkg, "files") else pkg)
