"""The engineer with only a rig: a stated class, a design certified for all of it."""
import fl_design as fl

cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3, u_limits=(-10.0, 10.0))
print(cls.describe())
tuning = fl.tune(cls)
print(tuning)
