"""What to bake: BakeSettings, the Python twin of the C++ SDK's
impostor::sdk::BakeSettings (client/include/impostor/client.h documents every
field's meaning, default and range; the server checks the ranges)."""
from __future__ import annotations

import dataclasses
from typing import Any, Dict, List, Mapping, Optional

import grpc

from .errors import ImpostorError

LAYOUTS = ("octahedral", "hemi-octahedral", "azimuth-elevation", "ring-top", "billboard")
PRODUCTS = ("atlas", "surfels", "lod-chain", "cards")


def _named_value(field: str, name: str, values: Dict[str, Any]) -> Any:
    """The enum value called `name`; INVALID_ARGUMENT listing the names otherwise."""
    if name not in values:
        expected = ", ".join(n for n in values if n)
        raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, f'{field}: unknown {field} "{name}"; expected {expected}')
    return values[name]


def _set_field(message: Any, name: str, value: Any) -> None:
    """message.name = value; a value of the wrong type or out of the field's
    range is INVALID_ARGUMENT naming the setting."""
    field = message.DESCRIPTOR.fields_by_name[name]
    repeated = field.label == field.LABEL_REPEATED
    why = ""
    if repeated and not isinstance(value, (list, tuple)):
        why = "expected a list"
    elif isinstance(value, bool) and field.type != field.TYPE_BOOL:
        why = "expected a number, not True/False"  # protobuf takes a bool as 0 or 1
    if not why:
        try:
            if repeated:
                getattr(message, name).extend(value)
            else:
                setattr(message, name, value)
            return
        except (TypeError, ValueError, AttributeError) as e:
            why = str(e)
    raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, f"{name}: {value!r} is not valid here ({why})")


@dataclasses.dataclass
class BakeSettings:
    """What to bake. Zero, empty and None mean "the server's default".

    layout: "octahedral" (default), "hemi-octahedral", "azimuth-elevation",
        "ring-top" or "billboard"; "" = the server's default.
    frames: frames per atlas axis; 0 = default (12). Server range 2..64.
    resolution: atlas side in pixels; 0 = default (2048). Range 64..16384.
    product: "atlas" (default), "surfels", "lod-chain" or "cards".
    ring_views, supersampling, preset, point_budget, lod_ratios,
    lod_pixel_error, max_planes, tolerance, quality_views, emissive,
    texture_array, frames_auto: as BakeSettings in the C++ SDK.
    priority: -100..100, higher runs first; not part of the cache key.
    required_tags: worker tags (impostor-worker --tags) a worker must have
        to bake this, e.g. ["gpu"]; not part of the cache key.
    min_iou, min_psnr_db: quality gate (the job fails with
        FAILED_PRECONDITION below them); not part of the cache key.
    follow_symlinks: upload files reached through a symbolic link that leads
        out of the model's folder (default: refuse with PERMISSION_DENIED).
    texture_format: "png" (default) or "ktx2" (Basis Universal UASTC in KTX2
        with the farm's own per-tile mip chain, docs/ktx2.md); "" = default.
    albedo_codec: ktx2 only: "uastc" (default) or "uastc-rdo"; "" = default.
    """

    layout: str = "octahedral"
    frames: int = 0
    resolution: int = 0
    product: str = "atlas"
    ring_views: Optional[int] = None
    supersampling: Optional[int] = None
    preset: str = ""
    point_budget: Optional[int] = None
    lod_ratios: List[float] = dataclasses.field(default_factory=list)
    lod_pixel_error: Optional[float] = None
    max_planes: Optional[int] = None
    tolerance: Optional[float] = None
    quality_views: Optional[int] = None
    emissive: bool = False
    texture_array: bool = False
    frames_auto: bool = False
    priority: int = 0
    required_tags: List[str] = dataclasses.field(default_factory=list)
    min_iou: Optional[float] = None
    min_psnr_db: Optional[float] = None
    follow_symlinks: bool = False
    texture_format: str = ""
    albedo_codec: str = ""

    @classmethod
    def from_kwargs(cls, settings: Mapping[str, Any]) -> "BakeSettings":
        """BakeSettings from keyword arguments; an unknown name is INVALID_ARGUMENT
        naming it and the known ones."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(settings) - known)
        if unknown:
            raise ImpostorError(
                grpc.StatusCode.INVALID_ARGUMENT,
                f"unknown bake setting(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}",
            )
        return cls(**dict(settings))

    def to_parameters(self) -> Any:
        """The impostor.v1.BakeParameters message; INVALID_ARGUMENT for an
        unknown layout or product."""
        from .v1 import types_pb2 as pb

        p = pb.BakeParameters()
        p.layout = _named_value("layout", self.layout, {
            "": pb.LAYOUT_UNSPECIFIED,
            "octahedral": pb.LAYOUT_OCTAHEDRAL,
            "hemi-octahedral": pb.LAYOUT_HEMI_OCTAHEDRAL,
            "azimuth-elevation": pb.LAYOUT_AZIMUTH_ELEVATION,
            "ring-top": pb.LAYOUT_RING_TOP,
            "billboard": pb.LAYOUT_BILLBOARD,
        })
        p.product = _named_value("product", self.product, {
            "": pb.PRODUCT_UNSPECIFIED,
            "atlas": pb.PRODUCT_UNSPECIFIED,  # the server's default
            "surfels": pb.PRODUCT_SURFELS,
            "lod-chain": pb.PRODUCT_LOD_CHAIN,
            "cards": pb.PRODUCT_CARDS,
        })
        p.texture_format = _named_value("texture_format", self.texture_format, {
            "": pb.TEXTURE_FORMAT_UNSPECIFIED,
            "png": pb.TEXTURE_FORMAT_PNG,
            "ktx2": pb.TEXTURE_FORMAT_KTX2,
        })
        p.albedo_codec = _named_value("albedo_codec", self.albedo_codec, {
            "": pb.ALBEDO_CODEC_UNSPECIFIED,
            "uastc": pb.ALBEDO_CODEC_UASTC,
            "uastc-rdo": pb.ALBEDO_CODEC_UASTC_RDO,
        })
        for name in ("frames", "resolution", "preset", "ring_views", "supersampling", "point_budget",
                     "lod_pixel_error", "max_planes", "tolerance", "quality_views", "emissive",
                     "texture_array"):
            value = getattr(self, name)
            if value is not None:
                _set_field(p, name, value)
        _set_field(p, "lod_ratios", self.lod_ratios)
        # frames_auto's target is the request's gate: one pair of thresholds.
        if self.frames_auto:
            _set_field(p, "frames_auto", self.frames_auto)
            if self.min_iou is not None:
                _set_field(p.auto_target, "min_iou", self.min_iou)
            if self.min_psnr_db is not None:
                _set_field(p.auto_target, "min_psnr_db", self.min_psnr_db)
        return p

    def apply_scheduling(self, request: Any) -> None:
        """Sets the SubmitBakeRequest's priority and quality gate;
        INVALID_ARGUMENT naming the setting for a value of the wrong type."""
        _set_field(request, "priority", self.priority)
        if self.required_tags:
            _set_field(request, "required_tags", self.required_tags)
        if self.min_iou is not None:
            _set_field(request.gate, "min_iou", self.min_iou)
        if self.min_psnr_db is not None:
            _set_field(request.gate, "min_psnr_db", self.min_psnr_db)

    def validate(self) -> None:
        """Every setting's type, before anything is uploaded: the errors
        to_parameters and apply_scheduling would raise (the server checks the
        ranges)."""
        from .v1 import bake_service_pb2 as bake_pb

        self.to_parameters()
        self.apply_scheduling(bake_pb.SubmitBakeRequest())
