"""A library's robot description (URDF) as skatelib hands it to the parsers that load geometry
(pinocchio's visual model for ``inspect``, MuJoCo for the twin): without mesh files.

The URDF is the library's text, and a library may come from anyone: a ``<mesh filename="...">``
would make those parsers open a path of the file's choosing (``/etc/shadow``, a local ``.obj``
then drawn into a recording). skatelib draws and builds the robot from the URDF's primitive
shapes (boxes, cylinders, spheres), so the ``<visual>`` and ``<collision>`` elements whose
geometry is a mesh are dropped, and so is every ``<texture>``. pinocchio's kinematic model
(``buildModelFromXML``, the controller's) reads no file and gets the text as stored.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from skatelib.library.errors import ModelError

_SHAPES = ("visual", "collision")


def _tree(urdf: str) -> ET.Element:
    try:
        return ET.fromstring(urdf)
    except ET.ParseError as e:
        raise ModelError(f"the robot description (URDF) is not well-formed XML: {e}") from e


def mesh_files(urdf: str) -> list[str]:
    """The file names of the URDF's meshes and textures, in order (none read).

    Raises:
        ModelError: The text is not well-formed XML.
    """
    if "mesh" not in urdf and "texture" not in urdf:
        return []
    root = _tree(urdf)
    return [e.get("filename", "") for e in root.iter() if e.tag in ("mesh", "texture")]


def without_meshes(urdf: str) -> str:
    """The URDF without the ``<visual>`` and ``<collision>`` elements whose geometry is a mesh and
    without ``<texture>`` elements; the text itself when it names neither.

    Raises:
        ModelError: The text is not well-formed XML.
    """
    if not mesh_files(urdf):
        return urdf
    root = _tree(urdf)
    for parent in list(root.iter()):
        for child in list(parent):
            if child.tag == "texture" or (child.tag in _SHAPES and child.find("geometry/mesh") is not None):
                parent.remove(child)
    return ET.tostring(root, encoding="unicode")
