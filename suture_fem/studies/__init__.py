"""Studies built on the core pipeline: verification, convergence, sweep, reproduce, maxload, hard cases."""
