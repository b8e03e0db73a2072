"""From a study table to a design decision: replicate statistics, surrogate models, global
sensitivity (the stage between ``study`` and ``report``)."""
