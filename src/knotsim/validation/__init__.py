"""Validation against analytical and published results (``knotsim validate``).

Cases live in :mod:`knotsim.validation.cases`: ``CASES`` maps a case name to its function and
``run_cases(names, quick)`` runs them, returning one dict per checked quantity (keys ``case``,
``quantity``, ``value``, ``reference``, ``error``, ``tolerance``, ``passed``, ``wall_time``).
"""
