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

:mod:`pipeflex.plot.centreline` computes the centre lines without drawing.
"""
from .animation import animate, save
from .centreline import centre_line, centre_line_from_frames, mode_displacement
from .charts import campbell, stability_map, work_precision
from .modes import mode_shape
from .roots import eigenvalue_paths, root_locus, root_locus_figure
from .structure import model, supports

__all__ = ["model", "supports", "mode_shape", "animate", "save", "campbell", "stability_map", "work_precision",
           "root_locus", "eigenvalue_paths", "root_locus_figure", "centre_line", "centre_line_from_frames",
           "mode_displacement"]
