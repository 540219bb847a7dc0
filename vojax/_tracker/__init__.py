"""A joint Bayesian tracker of the order, the parameters and the output offset: an iterated
extended Kalman filter (online) and an iterated extended Kalman smoother (offline)."""

from ._filter import KalmanTracker as KalmanTracker
from ._kalman import kalman_filter as kalman_filter
from ._kalman import rts_smoother as rts_smoother
from ._model import Hyper as Hyper
from ._track import TrackResult as TrackResult
from ._track import Tuning as Tuning
from ._track import track as track
