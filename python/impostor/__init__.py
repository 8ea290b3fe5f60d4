"""Python client of the impostor bake farm.

Bakes glTF models into impostor atlases (and cards, LOD chains, surfel
clouds) on an impostor-server, with the cache, retries and errors of the C++
SDK (client/include/impostor/client.h). Start with Client.
"""
from ._retry import ConnectionEvent
from .client import Client
from .errors import ImpostorError
from .release import FetchedAsset, ReleaseClient, ReleaseError
from .results import (
    BakeResult,
    BatchSubmission,
    FetchResult,
    JobUpdate,
    LookupResult,
    SubmitResult,
    UploadStats,
)
from .settings import BakeSettings

__all__ = [
    "BakeResult",
    "BakeSettings",
    "BatchSubmission",
    "Client",
    "ConnectionEvent",
    "FetchResult",
    "FetchedAsset",
    "ImpostorError",
    "JobUpdate",
    "LookupResult",
    "ReleaseClient",
    "ReleaseError",
    "SubmitResult",
    "UploadStats",
]
__version__ = "0.1.0"
