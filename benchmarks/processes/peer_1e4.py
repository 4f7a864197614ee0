# the peer scene (bench_limit_cycle.scene), 2 s at h = 1.2 ms with the defaults (1e-4 m): whole process;
# with an argument, that step [s] instead (peer_1e4.py 1e-4: h = 0.1 ms, 1e-6 m)
import sys

import pipeflex as pf
sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
b = pf.ModelBuilder()
n0 = b.add_node((0.0, 0.0, 0.0))
nodes = b.add_line(n0, (1.0, 0.0, 0.0), 8, sec)
b.clamp(n0)
b.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
model = b.build(mass_flow=30.0)
st = pf.static_equilibrium(model, mass_flow=0.0).state
res = pf.simulate(model, 2.0, state=st, n_outputs=2, progress=False, integrator="generalized_alpha", step=float(sys.argv[1]) if len(sys.argv) > 1 else 1.2e-3)
print(float(res.x[-1, nodes[-1], 1]))
