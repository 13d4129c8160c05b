"""Bundled example products (YAML), shipped with the package; see README."""
