"""Files that ship inside the package: the bundled example robot and its demo suite."""

from importlib import resources
from pathlib import Path


def path(name: str) -> Path:
    """Filesystem path of a bundled asset (the package is installed unzipped)."""
    return Path(str(resources.files(__package__).joinpath(name)))


ROBOT_XML = "robot.xml"
