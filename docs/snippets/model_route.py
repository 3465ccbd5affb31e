"""The engineer with a model: a library plant, its class, a design, a run and a certificate."""
import fl_design as fl

plant = fl.plants.pendulum(c=0.05)                  # a lightly damped pendulum, rho = 2
cls = fl.PlantClass.from_plant(plant)               # what the theory assumes, by interval enclosures
print(cls.describe())
design = fl.presets.pendulum_design(eps=0.03)       # EHGO + dynamic controller, T = 1 ms
resp = fl.simulate(plant, design, fl.Scenario(0.1))
print(resp.status, f"overshoot {100 * resp.overshoot:.1f} %")
cert = fl.certify_eps(design, cls)                  # certifies every plant of the class
print(f"eps = {cert.eps:g} certified: {cert.certified}; "
      f"certified eps* {cert.eps_star_certified:.4g}")
print("linearized eps* of this plant:", fl.linearized_eps_star(plant, design))
