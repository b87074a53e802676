"""Texture-by-numbers' guides (laitoch2018 §3.1-3.4): label maps encoded and turned into guide
channels and per-level label tables (:mod:`.channels`), the guide the solver is given and what
each level's kernels take from it (:mod:`.guidance`), the coarsest level's initialisation
(:mod:`.initialization`, §3.4) and their numba kernels (:mod:`._kernels`).

Used within :mod:`barkgen.synth` only; other packages reach these through
:mod:`barkgen.synth`'s face. Nothing is imported here, so that a module of the solver's core
may import one of these without running the package's face.
"""
