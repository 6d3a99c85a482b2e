"""The component contracts at the path plugins import them from (``from pftrack.components
import Likelihood, Param``): every public name of :mod:`pftrack.contracts.components`, and
:data:`~pftrack.contracts.kinds.KINDS`. The definitions and their documentation live there."""

from pftrack.contracts.components import *  # noqa: F403
from pftrack.contracts.kinds import KINDS as KINDS
