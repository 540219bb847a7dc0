"""vojax: identification of variable-order fractional systems in JAX."""

from . import io as io
from . import reference as reference
from . import testing as testing
from ._adaptive import (
    LSFF as LSFF,
)
from ._adaptive import (
    AdaptiveLaw as AdaptiveLaw,
)
from ._adaptive import (
    OrderGradient as OrderGradient,
)
from ._adaptive._estimator import LawEstimator as LawEstimator
from ._compare import Comparison as Comparison
from ._compare import compare as compare
from ._design import Design as Design
from ._design import fisher_information as fisher_information
from ._diagnostics import Diagnostics as Diagnostics
from ._diagnostics import IdentifiabilityWarning as IdentifiabilityWarning
from ._diagnostics import Reason as Reason
from ._identification import Conditional as Conditional
from ._identification import Identification as Identification
from ._identify import identify as identify
from ._integral import (
    fractional_integral as fractional_integral,
)
from ._integral import (
    order_sensitivity as order_sensitivity,
)
from ._kernels import (
    AbstractMemory as AbstractMemory,
)
from ._kernels import (
    DirectMemory as DirectMemory,
)
from ._kernels import (
    ExponentialMemory as ExponentialMemory,
)
from ._kernels import (
    GridDirectMemory as GridDirectMemory,
)
from ._models import (
    AbstractViscoelasticModel as AbstractViscoelasticModel,
)
from ._models import (
    FractionalMaxwell as FractionalMaxwell,
)
from ._models import (
    FractionalZener as FractionalZener,
)
from ._models import (
    KelvinVoigt as KelvinVoigt,
)
from ._models import (
    Springpot as Springpot,
)
from ._models import (
    stress_strain as stress_strain,
)
from ._models._closed import mittag_leffler as mittag_leffler
from ._models._closed_jax import mittag_leffler_jax as mittag_leffler_jax
from ._protocol import optimal_protocol as optimal_protocol
from ._refit import Refit as Refit
from ._refit import RefitWarning as RefitWarning
from ._refit import refit as refit
from ._refit import refit_lbfgsb as refit_lbfgsb
from ._results import Summary as Summary
from ._settling import SettlingTest as SettlingTest
from ._settling import settling_test as settling_test
from ._simulate import simulate as simulate
from ._steps import Step as Step
from ._study import simulate_study as simulate_study
from ._study import study_signals as study_signals
from ._tracker import Tracker as Tracker
from ._tracker import TrackerSettings as TrackerSettings
from ._tune import Gains as Gains
from ._tune import tune_gains as tune_gains
from ._version import version as _version
from ._xla import use_compilation_cache as use_compilation_cache
from ._xla import use_fast_cpu_loops as use_fast_cpu_loops
from .io import load_records as load_records
from .io import write_results as write_results

__version__ = _version()
