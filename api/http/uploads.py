"""Upload bodies of the CSV routes: a file sent raw (``curl --data-binary @run.csv``,
``Content-Type: text/csv``) or as the one file of a multipart form (``curl -F
file=@run.csv``, a browser form). The body cap is ``api.http.limits.BodyLimit``'s either way;
multipart is parsed by python-multipart through Starlette, spooled to disk past 1 MiB."""

from __future__ import annotations

from pathlib import Path

from starlette.datastructures import UploadFile
from starlette.requests import Request

MULTIPART = "multipart/form-data"
#: Form fields a CSV upload may carry besides its file (a browser form's extra inputs), and
#: files parsed before one too many is refused (so the refusal can say how many came).
MAX_FIELDS = 16
MAX_FILES = 4
CHUNK = 1 << 20


def is_multipart(request: Request) -> bool:
    return request.headers.get("content-type", "").lower().startswith(MULTIPART)


async def _the_file(request: Request) -> UploadFile:
    form = await request.form(max_files=MAX_FILES, max_fields=MAX_FIELDS)
    files = [value for value in form.values() if isinstance(value, UploadFile)]
    if len(files) != 1:
        raise ValueError(
            f"file: a multipart upload needs one file field (e.g. curl -F file=@run.csv), "
            f"got {len(files)}"
        )
    return files[0]


async def save_upload(request: Request, path: Path) -> str | None:
    """Write the uploaded CSV to ``path``; returns the file name a multipart part gave
    (None for a raw body)."""
    with open(path, "wb") as out:
        if not is_multipart(request):
            async for chunk in request.stream():
                out.write(chunk)
            return None
        upload = await _the_file(request)
        while chunk := await upload.read(CHUNK):
            out.write(chunk)
        await upload.close()
        return upload.filename


async def upload_bytes(request: Request) -> bytes:
    """The uploaded CSV as bytes (small tables: the calibration import)."""
    if not is_multipart(request):
        return await request.body()
    upload = await _the_file(request)
    data = await upload.read()
    await upload.close()
    return data
