"""The MIT Lincoln Laboratory Bayesian-network encounter models: reader (model), sampler (sampler), 1 Hz
trajectories (tracks). The shipped parameter files are in models/ with their LICENSE (BSD 2-Clause, MIT)."""
