"""File output: safe output folders (:mod:`~psdesign.io.outputs`) and atomic writes
(:mod:`~psdesign.io.atomic`)."""
