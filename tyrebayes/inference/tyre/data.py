"""Observations for the per-tyre model: short-window averages of slip and normalised force.

Why windows: a one-hour 100 Hz drive has 360,000 samples, each with slip noise of the same size
as the slip itself. Averaging over ~0.25 s keeps the slow true slip (it follows the driver's
pedal) while dividing the white sensor noise variance by the window length, and it reduces the
data the sampler touches by the same factor. The remaining noise in *both* slip and force is
handled by the errors-in-variables likelihood of :mod:`tyrebayes.inference.tyre.model`.

The names live one concept per module and are re-exported here, where callers import them:

* :mod:`~tyrebayes.inference.tyre.windows`: one drive's windows
  (:func:`windowed_observations`, :func:`observations_from_features`), a
  :class:`WindowTable` (:mod:`~tyrebayes.inference.tyre.window_table`);
* :mod:`~tyrebayes.inference.tyre.observations`: several drives stacked and padded to a
  fixed bucket size with a mask, so that new data of the same bucket reuse the compiled model
  (:class:`TyreObservations`, :func:`stack_drives`, :func:`bucket_size`);
* :mod:`~tyrebayes.inference.tyre.from_stream`: a stream file to windows
  (:func:`windows_from_stream`, :func:`observations_from_stream`).
"""

from __future__ import annotations

from ..._domain import SURFACES as SURFACES
from .from_stream import observations_from_stream as observations_from_stream
from .from_stream import windows_from_stream as windows_from_stream
from .observations import BLOCK_S as BLOCK_S
from .observations import TyreObservations as TyreObservations
from .observations import bucket_size as bucket_size
from .observations import stack_drives as stack_drives
from .window_table import WindowTable as WindowTable
from .windows import PUSHING_MARGIN as PUSHING_MARGIN
from .windows import observations_from_features as observations_from_features
from .windows import window_centres as window_centres
from .windows import windowed_observations as windowed_observations
