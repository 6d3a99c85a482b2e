"""Where the sample data is, at the path notebooks import it from
(``from pftrack.data import data_dir``): :mod:`pftrack.io.data`, where it is defined and
documented."""

from pftrack.io.data import data_dir as data_dir
from pftrack.io.data import data_path as data_path
from pftrack.io.data import pets09_files as pets09_files
