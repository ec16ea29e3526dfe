"""Support: dolfinx-version compatibility, rank-0 work with collective outcomes, files, errors, logging."""
