"""Many runs at once (``pftrack batch``), at the path scripts import it from
(``pftrack.batch.run_batch``): every public name of :mod:`pftrack.workflows.batch`, where they
are defined and documented."""

from pftrack.workflows.batch import *  # noqa: F403
from pftrack.workflows.batch import WORKER_CONFIG as WORKER_CONFIG
