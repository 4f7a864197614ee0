"""Figures of a user's model and of analysis results (matplotlib, imported on use).

Every function takes keyword-only options, draws on ``ax`` (new axes if None) and
returns the axes (:func:`animate`: the animation). Units are in the axis labels.

* :func:`model` - a model: centre line (shape functions), supports, hinges, loads, flow.
* :func:`mode_shape` - a mode shape drawn with the shape functions.
* :func:`animate`, :func:`save` - an animation of a transient result; mp4 or gif.
* :func:`campbell` - a Campbell diagram (:func:`pipeflex.campbell`).
* :func:`stability_map` - critical flow speed and frequency against the mass ratio.
* :func:`work_precision` - error against wall time of several methods.
* :func:`root_locus`, :func:`eigenvalue_paths`, :func:`root_locus_figure` - eigenvalues
  as the mass flow varies.
* :func:`bifurcation` - amplitude or period of branches of periodic orbits against the
  mass flow (solid stable, dashed unstable, Hopf points).
* :func:`time_history` - quantities against time.
* :func:`parameter_curves` - quantities against a parameter (sweeps, refinements).
* :func:`comparison` - computed curves against published values.
* :func:`published_points` - published values in the package's style (open circles;
  :data:`STYLES` holds the styles of computed and published values).
* :func:`label_points` - labels next to points, placed so that they do not overlap.
* :func:`error_cost` - error against cost of several models, grouped.
* :func:`paths` - centre lines or trajectories drawn in a plane.
* :func:`deviation_map` - a table of relative deviations as a colour map.

:mod:`pipeflex.plot.centreline` computes the centre lines without drawing.
"""
from .animation import animate, save
from .bifurcation import bifurcation
from .centreline import centre_line, centre_line_from_frames, mode_displacement
from .charts import campbell, deviation_map, stability_map, work_precision
from .curves import (STYLES, comparison, error_cost, label_points, parameter_curves, paths, published_points,
                     time_history)
from .modes import mode_shape
from .roots import eigenvalue_paths, root_locus, root_locus_figure
from .structure import model, supports

__all__ = ["model", "supports", "mode_shape", "animate", "save", "campbell", "stability_map", "work_precision",
           "root_locus", "eigenvalue_paths", "root_locus_figure", "centre_line", "centre_line_from_frames",
           "mode_displacement", "bifurcation", "time_history", "parameter_curves", "comparison", "error_cost",
           "paths", "deviation_map", "published_points", "label_points", "STYLES"]
