"""The fit: the middle of pendfmu's flow, from a recording to a result.

    recording -> experiment -> simulator -> residuals -> optimizer -> result -> report/export

experiment (what a fit needs from one recording), residuals (the output error as a function
of the free parameters), optimizer (seeded global search, local refinement), workers (what
runs in worker processes), pool and cluster (local and Dask workers that a fit survives),
checkpoint (interrupted fits), uncertainty, bootstrap and
stiction (the intervals and sets of the result), plausibility (warnings about the data),
result (FitResult), identification (the stages of the paper and `fit`).

Named `fitting`, not `fit`: ``pendfmu.fit`` is the function users call, and importing a
package of that name would replace it.
"""
