"""A joint Bayesian tracker of the order, the parameters and the output offset: an iterated
extended Kalman filter (online) and an iterated extended Kalman smoother (offline)."""

from .._settings import TrackerSettings as TrackerSettings
from ._estimator import Tracker as Tracker
from ._filter import KalmanTracker as KalmanTracker
from ._fit import TrackResult as TrackResult
from ._kalman import kalman_filter as kalman_filter
from ._kalman import rts_smoother as rts_smoother
from ._model import Hyper as Hyper
from ._tuning import Tuning as Tuning
