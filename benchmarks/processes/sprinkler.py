# the sprinkler, 1 s of motion at h = 1 ms, and its steady rotation
import pipeflex as pf
m = pf.scenes.sprinkler(EI=100.0)
r = pf.simulate(m, 1.0, integrator="generalized_alpha", step=1e-3, n_outputs=2, progress=False)
print(pf.steady_rotation(m).omega)
