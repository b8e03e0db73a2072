"""One validated schema (pydantic v2) of the RVE spec and the study file.

Modules, one job each:

* ``types``: the one number validator (:func:`~psdesign.schema.types.number`,
  :func:`~psdesign.schema.types.integer`) and the base :class:`~psdesign.schema.types.Table`
  (unknown keys are errors with a "did you mean");
* ``rve``, ``fibers``, ``distributions``, ``generator`` (also ``[intersections]``), ``flow``,
  ``forcefield``: the tables;
* ``document``: the whole spec and its cross-field checks; ``budget``: up-front memory/time
  estimates;
* ``study``: ``[study]`` and the parameter value forms;
* ``errors``: pydantic errors -> one line ``KEY: message (allowed: ...)``;
* ``keys``: every key as a dotted path (study parameter paths, docs tables); ``docs``:
  generates ``docs/spec-keys.md``;
* ``spec``: :func:`~psdesign.schema.spec.load_spec` / :func:`~psdesign.schema.spec.validate_spec`.
"""
