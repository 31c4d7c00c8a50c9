"""Surfaces in R^4 polygonized once: Mesh4D, parametric tessellation, the implicit polygonizer."""

from exhibit.surfaces.mesh import Curve, Marker, Material, Mesh4D, Surface
from exhibit.surfaces.parametric import Interval, tessellate
from exhibit.surfaces.topology import TopologyReport, analyse

__all__ = [
    "Curve",
    "Interval",
    "Marker",
    "Material",
    "Mesh4D",
    "Surface",
    "TopologyReport",
    "analyse",
    "tessellate",
]
