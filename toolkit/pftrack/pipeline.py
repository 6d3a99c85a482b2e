"""What ``pftrack run`` does, at the path scripts and notebooks import it from
(``from pftrack.pipeline import load_config, run_pipeline``): every public name of
:mod:`pftrack.workflows.pipeline`, where they are defined and documented."""

from pftrack.workflows.pipeline import *  # noqa: F403
