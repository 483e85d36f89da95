"""The area a REST client may ask for: :class:`AreaSpec` with the bounds that keep it plannable.

The coverage planner takes any positive spacing and any [lat, lon]; a request must not, because
nonsense there is not a refusal but a crash or an endless plan (issue 11): a spacing of 1e-300 m
divides by zero, a camera of 1e-300 mm gives that spacing too, a triangle around a pole has no
local plane to be planned in, and thousands of vertices over many holes take minutes. These
bounds turn each into a 422 with the reason, and the OpenAPI schema publishes them.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from dronefleet.ground.planner.coverage import AreaSpec, CameraSpec
from dronefleet.ground.planner.coverage.spec import MAX_VERTICES

#: Closest swaths or pictures (m): well under any camera's useful footprint, and above the
#: scale where the planner's geometry tolerances (millimetres) stop being small.
MIN_SPACING_M = 0.5
#: The Web Mercator limit the map uses; nearer a pole, the tangent plane the planner works in
#: no longer holds a field drawn in latitude and longitude.
MAX_ABS_LAT = 85.0
#: Vertices of the polygon and all its holes together (each ring alone may have MAX_VERTICES).
MAX_TOTAL_VERTICES = MAX_VERTICES
#: Largest image a camera may declare (px per side).
MAX_IMAGE_PX = 100_000

Latitude = Annotated[float, Field(ge=-MAX_ABS_LAT, le=MAX_ABS_LAT)]
Longitude = Annotated[float, Field(ge=-180, le=180)]
Vertex = tuple[Latitude, Longitude]


class CameraRequest(CameraSpec):
    """A nadir camera as a request may give it (dimensions of real cameras)."""

    sensor_width_mm: float = Field(ge=0.1, le=100)
    sensor_height_mm: float = Field(ge=0.1, le=100)
    focal_length_mm: float = Field(ge=0.1, le=1000)
    image_width_px: int = Field(ge=1, le=MAX_IMAGE_PX)
    image_height_px: int = Field(ge=1, le=MAX_IMAGE_PX)


class AreaRequest(AreaSpec):
    """An area to cover, bounded so that planning it ends with a plan or a reason."""

    # Redeclared with tighter bounds; AreaSpec's validators (rings, consistency) still run.
    polygon: list[Vertex] = Field(
        max_length=MAX_VERTICES, description="exterior, [lat, lon]s (|lat| <= 85)"
    )
    holes: list[list[Vertex]] = Field(
        default_factory=list, max_length=100, description="rings to keep out of"
    )
    spacing_m: float | None = Field(
        default=None, ge=MIN_SPACING_M, le=1000, description="line spacing"
    )
    camera: CameraRequest | None = None
    trigger_distance_m: float | None = Field(default=None, ge=MIN_SPACING_M, le=1000)
    angle_deg: float | None = Field(
        default=None, ge=-360, le=360, description="swath bearing, degrees from north; None: fewest"
    )

    @model_validator(mode="after")
    def _plannable(self) -> AreaRequest:
        total = len(self.polygon) + sum(len(h) for h in self.holes)
        if total > MAX_TOTAL_VERTICES:
            raise ValueError(
                f"the polygon and its holes have {total} vertices together;"
                f" at most {MAX_TOTAL_VERTICES}"
            )
        # A camera gives its spacings through its footprint: bound them as the given ones are.
        for what, metres in (("line spacing", self.line_spacing_m), ("trigger", self.trigger_m)):
            if metres < MIN_SPACING_M:
                raise ValueError(
                    f"the camera gives a {what} of {metres:.3g} m at {self.altitude_m:g} m;"
                    f" at least {MIN_SPACING_M:g} m (fly higher or check the camera)"
                )
        return self
