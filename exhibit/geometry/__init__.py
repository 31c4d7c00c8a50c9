"""Pure 4D geometry in the paper's conventions: numpy only — no GL, no devices, no I/O.

Everything the renderer, the scenes and the kiosk compute about rotations, projections, normals
and silhouettes lives here, so it can be checked against the paper without a GPU.
"""

from exhibit.geometry.cross import bivector_norm, cross4, generalized_cross
from exhibit.geometry.normals import (
    complement_plane,
    normals_from_tangents,
    projected_normal_from_normals,
    projected_normal_from_tangents,
    tangents_from_normals,
)
from exhibit.geometry.pipeline import ClipTransform, clip_transform, sensor_matrix
from exhibit.geometry.projection import (
    Projected,
    eye_ray,
    project_to_2d,
    project_to_3d,
    sensor_depth,
    sensor_jacobian,
    sensor_ray,
)
from exhibit.geometry.rotations import (
    dimension_for_angle_count,
    euler_angle_count,
    euler_planes,
    euler_to_matrix,
    matrix_to_euler,
    plane_rotation,
)
from exhibit.geometry.silhouette import (
    is_silhouette_point_2d,
    is_silhouette_point_3d,
    lemma2_measure_normals,
    lemma2_measure_tangents,
    lemma3_measure_tangents,
    silhouette_function,
    silhouette_function_normalized,
    zero_set_segments,
)
from exhibit.geometry.view import ViewState

__all__ = [
    "ClipTransform",
    "Projected",
    "ViewState",
    "bivector_norm",
    "clip_transform",
    "complement_plane",
    "cross4",
    "dimension_for_angle_count",
    "euler_angle_count",
    "euler_planes",
    "euler_to_matrix",
    "eye_ray",
    "generalized_cross",
    "is_silhouette_point_2d",
    "is_silhouette_point_3d",
    "lemma2_measure_normals",
    "lemma2_measure_tangents",
    "lemma3_measure_tangents",
    "matrix_to_euler",
    "normals_from_tangents",
    "plane_rotation",
    "project_to_2d",
    "project_to_3d",
    "projected_normal_from_normals",
    "projected_normal_from_tangents",
    "sensor_depth",
    "sensor_jacobian",
    "sensor_matrix",
    "sensor_ray",
    "silhouette_function",
    "silhouette_function_normalized",
    "tangents_from_normals",
    "zero_set_segments",
]
