# seed 002: rotating cantilever frequencies at 3 speeds (10 ANCF elements)
import pipeflex as pf
m = pf.scenes.rotating_cantilever(n_elements=10)
print(pf.rotating_frequencies(m, gamma=[1.0, 5.0, 10.0]).transverse[:, 0])
