"""Compile settings shared by every compiled kernel: the loop's passes, the contact laws, the fluids.

One place, so that a law and the loop that inlines it are compiled with the same fast-math flags
(a callee compiled with other flags is not inlined the same way, and gives other numbers).
"""

from numba.core.cpu_options import ParallelOptions

# Fast-math without the no-NaN/no-inf assumptions, so that the engine's NaN guard still sees NaN,
# and without reassociation: LLVM reorders sums differently where it inlines one compiled function
# into another, and it inlines a callee compiled in the same process but not one loaded from the
# disk cache, so the same case gave other numbers on its first run than on later ones
# (docs/results/reproducibility.md; dropping it cost no speed there).
# A dict, not a set: numba keys the disk cache of a closure by its pickled cells, and a set of
# strings pickles in a per-process order (hash randomisation), so every process would recompile.
FAST = {"contract": True, "arcp": True, "afn": True, "nsz": True}
# Only the prange loops run in parallel: no numpy call or array expression becomes a parallel loop,
# and consecutive loops are not fused (each pass reads what the one before wrote for other blocks).
# An options object, not a dict: numba pops the keys of a dict given as ``parallel=`` when it
# compiles, so a pass compiled in this process pickled differently from one loaded from the disk
# cache, and every closure holding it (the implicit solve) missed the cache in the next process
# and was recompiled against callees it could no longer inline: with fast-math, other numbers
# (docs/results/reproducibility.md).
PRANGE_ONLY = ParallelOptions(dict(comprehension=False, reduction=False, inplace_binop=False,
                                   setitem=False, numpy=False, stencil=False, fusion=False))
