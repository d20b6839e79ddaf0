"""User management over HTTP: list, add, remove users and rotate a token (``rig user`` on
the command line). Admin only: the service's own token (user ``default``, ``rig token``),
which has the same authority as a shell on the service's database."""

from __future__ import annotations

from typing import Literal

from fastapi import Depends, HTTPException, Request
from pydantic import BaseModel, ConfigDict, Field

from api.http.app_codes import app_router
from api.http.deps import Credentials, StoreDep
from api.http.identity import DEFAULT_USER, known_user
from api.http.schemas import error_responses
from daq.store.people_and_safety_log import User, UserExists, UserRepository, check_user_name
from daq.store.run_records import to_datetime

router = app_router("/api/users", "people")
_ADMIN = error_responses(401, 403)


async def require_admin(request: Request, _: Credentials) -> User:
    """The service token's user; 403 for anyone else (named users cannot make users)."""
    user = await known_user(request)
    if user.name != DEFAULT_USER.name:
        raise HTTPException(
            403,
            f"user {user.name!r}: managing users needs the service token (`rig token`), the admin",
        )
    return user


class UserOut(BaseModel):
    name: str
    role: str
    created_at: str = Field(description="ISO 8601, UTC")


class NewUser(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(description="1-40 letters, digits or _.- starting with a letter.")
    role: Literal["operator", "viewer"] = Field(
        "viewer", description="operator: start, stop, change; viewer: read only."
    )


class TokenOut(BaseModel):
    name: str
    role: str
    token: str = Field(description="Shown only now; only its SHA-256 is stored.")


def _user_or_404(repo: UserRepository, name: str) -> User:
    found = repo.by_name(name)
    if found is None:
        raise HTTPException(404, f"name: no user named {name!r}")
    return found


@router.get(
    "", response_model=list[UserOut], dependencies=[Depends(require_admin)], responses=_ADMIN
)
def list_users(store: StoreDep) -> list[dict]:
    """Every named user (never a token); ``default`` is the service token itself."""
    return [
        r | {"created_at": to_datetime(r["created_at"]).isoformat()}
        for r in UserRepository(store).list()
    ]


@router.post(
    "",
    status_code=201,
    response_model=TokenOut,
    dependencies=[Depends(require_admin)],
    responses=error_responses(401, 403, 409, 422),
)
def add_user(body: NewUser, store: StoreDep) -> dict:
    """Add a user; its token is in the answer, once."""
    check_user_name(body.name)  # ValueError → 422 naming the field
    if body.name == DEFAULT_USER.name:
        raise ValueError("name: 'default' is not allowed (it is the service token's user)")
    try:
        token = UserRepository(store).add(body.name, body.role)
    except UserExists as err:
        raise HTTPException(409, str(err)) from None
    return {"name": body.name, "role": body.role, "token": token}


@router.delete(
    "/{name}",
    status_code=204,
    dependencies=[Depends(require_admin)],
    responses=error_responses(401, 403, 404),
)
def remove_user(name: str, store: StoreDep) -> None:
    """Remove a user: its token stops working at once."""
    if not UserRepository(store).remove(name):
        raise HTTPException(404, f"name: no user named {name!r}")


@router.post(
    "/{name}/token",
    response_model=TokenOut,
    dependencies=[Depends(require_admin)],
    responses=error_responses(401, 403, 404),
)
def rotate_token(name: str, store: StoreDep) -> dict:
    """Give a user a new token (shown once); the old one stops working at once."""
    repo = UserRepository(store)
    user = _user_or_404(repo, name)
    token = repo.rotate(name)
    if token is None:
        raise HTTPException(404, f"name: no user named {name!r}")
    return {"name": user.name, "role": user.role, "token": token}
