# seed 000 Table 2: five critical flows (2-32 elements)
import pipeflex as pf
print([pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=n)).mass_flow for n in (2, 4, 8, 16, 32)])
