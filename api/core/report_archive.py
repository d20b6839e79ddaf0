"""A stored result as one file to download: its report (report.md and the figures, PNG and
SVG) and result.json, in a zip named for the result."""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Sequence
from typing import Any


def archive_name(result_id: int) -> str:
    """``result-12-report.zip``: the download's file name."""
    return f"result-{result_id}-report.zip"


def report_zip(result: dict[str, Any], files: Sequence[tuple[str, bytes]]) -> bytes:
    """The zip of ``files`` (name, content) and ``result`` (the stored result document, as
    ``GET /api/results/{id}`` answers it) as result.json, all in one folder."""
    folder = archive_name(result["id"]).removesuffix(".zip")
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, content in files:
            archive.writestr(f"{folder}/{name}", content)
        text = json.dumps(result, indent=2, ensure_ascii=False)
        archive.writestr(f"{folder}/result.json", text)
    return buffer.getvalue()
