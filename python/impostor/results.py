"""What the Client's calls return. Plain dataclasses, no gRPC types."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Dict, List, Optional

from .errors import ImpostorError

#: Job states, as JobUpdate.state spells them.
TERMINAL_STATES = ("succeeded", "failed", "cancelled")


@dataclasses.dataclass(frozen=True)
class UploadStats:
    """What a submit sent to the store."""

    files: int = 0  # files of the model, the entry file included
    uploaded: int = 0  # files the server lacked and that were uploaded
    bytes_total: int = 0
    bytes_uploaded: int = 0


@dataclasses.dataclass(frozen=True)
class JobUpdate:
    """A snapshot of a job.

    state: "queued", "running", "succeeded", "failed", "cancelled" or "unknown".
    progress: fraction done, 0..1 (1 once succeeded).
    stage: while running, "download", "load", "render", "encode" or "upload".
    error_code, error_message: when failed or cancelled, a canonical status
        code number (3 = INVALID_ARGUMENT, 9 = FAILED_PRECONDITION...) and why.
    cached: the result came from the cache without a new bake.
    """

    job_id: str
    cache_key: str
    state: str
    progress: float = 0.0
    stage: str = ""
    error_code: int = 0
    error_message: str = ""
    cached: bool = False

    @property
    def terminal(self) -> bool:
        """True when the job will not change again."""
        return self.state in TERMINAL_STATES


@dataclasses.dataclass(frozen=True)
class SubmitResult:
    """An accepted bake. cache_key (64 hex chars) names the result for fetch().
    error_code/error_message are set when a cached result failed the
    request's quality gate (the job is already failed; fetch still works)."""

    job_id: str
    cache_key: str
    cached: bool
    upload: UploadStats
    error_code: int = 0
    error_message: str = ""


@dataclasses.dataclass(frozen=True)
class BatchSubmission:
    """What submit_batch did with one item: `result` when submitted, else
    `error` (the model's own problem, the server's refusal of this request,
    or CANCELLED when the batch stopped before it)."""

    result: Optional[SubmitResult] = None
    error: Optional[ImpostorError] = None


@dataclasses.dataclass(frozen=True)
class FetchResult:
    """What fetch() left on disk.

    files: every file of the result (map images, .glb levels, ...) in
        manifest order, then manifest.json, each verified against its digest.
    manifest: manifest.json, parsed (the format consumers read; its fields
        are those of impostor.v1.Manifest in snake_case).
    bytes_downloaded / bytes_reused: received, or already present in the
        folder with the right digest and kept.
    """

    dir: Path
    manifest_path: Path
    files: List[Path]
    manifest: Dict[str, Any]
    bytes_downloaded: int = 0
    bytes_reused: int = 0
    warnings: List[str] = dataclasses.field(default_factory=list)
    seconds: float = 0.0


@dataclasses.dataclass(frozen=True)
class BakeResult:
    """A finished bake, downloaded: bake()'s answer.

    quality: the manifest's "quality" block (atlas products), or None.
    """

    cache_key: str
    job: JobUpdate
    submit: SubmitResult
    fetched: FetchResult

    @property
    def manifest(self) -> Dict[str, Any]:
        return self.fetched.manifest

    @property
    def quality(self) -> Optional[Dict[str, Any]]:
        q = self.fetched.manifest.get("quality")
        return q if isinstance(q, dict) else None

    @property
    def files(self) -> List[Path]:
        return self.fetched.files

    @property
    def dir(self) -> Path:
        return self.fetched.dir

    @property
    def cached(self) -> bool:
        return self.submit.cached


@dataclasses.dataclass(frozen=True)
class LookupResult:
    """lookup()'s answer: the cache key the model and settings map to, and
    whether a result is baked under it. manifest: when found, the result's
    impostor.v1.Manifest as a dict (proto field names)."""

    cache_key: str
    found: bool
    manifest: Optional[Dict[str, Any]] = None
