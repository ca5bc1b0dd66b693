"""The wiring: the one layer that reads the application config (:class:`~ftc_mj.config.RunConfig`) and
builds the components from it.

The components (``estimation``, ``control``, ``plant``, ``reconfiguration``) import neither the
application config nor this package: each receives its own typed settings model and the run context.
This package sits above them and below the simulation (``sim``), which calls it.
"""
