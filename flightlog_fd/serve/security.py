"""Tokens, browser sessions and CSRF for `fdlog serve`.

What: :class:`TokenSet` holds only the sha256 of each token (``--token-file``: one token per line,
blank lines and ``#`` comments ignored) and checks a presented token against every hash with
``hmac.compare_digest`` (constant time, no early exit). API clients send ``Authorization: Bearer
TOKEN``. A browser signs in once with a token (the login form) and gets a random session id in an
HttpOnly, SameSite=Strict cookie; every state-changing form and request of that session must also
carry its CSRF token (form field ``csrf`` or header ``X-CSRF-Token``), an HMAC of the session id
under a per-process secret. Sessions live in memory for ``SESSION_S`` (a restart signs everyone
out). Why: the server keeps no token in clear, and a page on another site cannot post to it with
the operator's cookie.
"""
from __future__ import annotations

import hashlib
import hmac
import secrets
import threading
import time
from pathlib import Path
from typing import Optional

from ..errors import FlightLogError

#: A browser session lasts this long after sign-in (seconds).
SESSION_S = 12 * 3600.0
#: Shortest token accepted from a token file (shorter ones are guessable).
MIN_TOKEN_CHARS = 16
SESSION_COOKIE = "fdlog_session"


def _hash(token: str) -> bytes:
    return hashlib.sha256(token.encode("utf-8")).digest()


class TokenSet:
    """The accepted tokens, as sha256 hashes only."""

    def __init__(self, tokens: list[str]):
        self._hashes = [_hash(t) for t in tokens]

    @staticmethod
    def from_file(path) -> "TokenSet":
        p = Path(path)
        try:
            lines = p.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as e:
            raise FlightLogError(p, f"cannot read the token file: {e.__class__.__name__}") from None
        tokens = [ln.strip() for ln in lines if ln.strip() and not ln.strip().startswith("#")]
        if not tokens:
            raise FlightLogError(p, "the token file holds no token (one per line)")
        short = [i for i, t in enumerate(tokens, 1) if len(t) < MIN_TOKEN_CHARS]
        if short:
            raise FlightLogError(p, f"token {short[0]} is shorter than {MIN_TOKEN_CHARS} characters")
        return TokenSet(tokens)

    def __len__(self) -> int:
        return len(self._hashes)

    def check(self, token: Optional[str]) -> bool:
        """Constant time in the token's content: compares with every hash, no early exit."""
        if not token:
            return False
        h = _hash(token)
        ok = False
        for known in self._hashes:
            ok |= hmac.compare_digest(h, known)
        return ok


class Sessions:
    """Signed-in browsers: session id -> expiry; CSRF tokens derived from the id."""

    def __init__(self):
        self._secret = secrets.token_bytes(32)
        self._ids: dict[str, float] = {}
        self._lock = threading.Lock()

    def create(self) -> str:
        sid = secrets.token_urlsafe(32)
        with self._lock:
            now = time.time()
            self._ids = {k: v for k, v in self._ids.items() if v > now}
            self._ids[sid] = now + SESSION_S
        return sid

    def valid(self, sid: Optional[str]) -> bool:
        if not sid:
            return False
        with self._lock:
            exp = self._ids.get(sid)
        return exp is not None and exp > time.time()

    def drop(self, sid: Optional[str]) -> None:
        with self._lock:
            self._ids.pop(sid or "", None)

    def csrf(self, sid: str) -> str:
        return hmac.new(self._secret, sid.encode(), hashlib.sha256).hexdigest()

    def csrf_ok(self, sid: Optional[str], token: Optional[str]) -> bool:
        if not sid or not token:
            return False
        return hmac.compare_digest(self.csrf(sid), token)


def bearer(header: Optional[str]) -> Optional[str]:
    """The token of an ``Authorization: Bearer TOKEN`` header, else None."""
    if not header:
        return None
    scheme, _, value = header.partition(" ")
    return value.strip() if scheme.lower() == "bearer" and value.strip() else None
