# seed 004: FFRF cantilever pipe, 2 bodies, 1 s at 30 kg/s
import pipeflex as pf
from pipeflex.multibody import simulate
s = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5)
r = simulate(s, 1.0, step=1e-3, mass_flow=30.0)
print(r.t[-1])
