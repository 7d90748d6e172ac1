"""Issuing, hashing, finding and revoking bearer tokens.

A token is 32 random bytes (``secrets.token_urlsafe``) with a readable prefix (``rks_`` student, ``rkt_``
teacher). Only its SHA-256 is stored: with that much entropy a fast hash is enough (a slow password hash protects
low-entropy secrets against guessing; nobody can guess 256 random bits). The token itself is returned once by
:func:`issue` and never stored, logged or shown again.
"""

from __future__ import annotations

import hashlib
import secrets

from django.db import transaction
from django.utils import timezone

from robokit.server.models import Classroom, Student, Token

PREFIXES = {Token.STUDENT: "rks_", Token.TEACHER: "rkt_"}


class TokenError(Exception):
    """A token that cannot be used: unknown, revoked, its teacher's account deactivated, or badly formed (the message
    says which, never the token)."""


def hash_token(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


@transaction.atomic
def issue_student_token(student: Student) -> str:
    """A new token for ``student``; their earlier tokens are revoked. Returns the token (shown once)."""
    Token.objects.filter(student=student, revoked_at__isnull=True).update(revoked_at=timezone.now())
    token = PREFIXES[Token.STUDENT] + secrets.token_urlsafe(32)
    Token.objects.create(kind=Token.STUDENT, key_hash=hash_token(token), classroom=student.classroom,
                         student=student)
    return token


def issue_teacher_token(classroom: Classroom, teacher: object) -> str:
    """A token for official runs in ``classroom`` (posted results are marked official). Returns it (shown once)."""
    token = PREFIXES[Token.TEACHER] + secrets.token_urlsafe(32)
    Token.objects.create(kind=Token.TEACHER, key_hash=hash_token(token), classroom=classroom, teacher=teacher)
    return token


def revoke_student_tokens(student: Student) -> int:
    """Revoke every active token of ``student``; returns how many."""
    return Token.objects.filter(student=student, revoked_at__isnull=True).update(revoked_at=timezone.now())


def find(token: str) -> Token:
    """The active :class:`Token` for ``token``.

    Raises:
        TokenError: unknown or revoked, or a teacher token whose account was deactivated.
    """
    row = (Token.objects.select_related("classroom", "student", "teacher")
           .filter(key_hash=hash_token(token)).first())
    if row is None:
        raise TokenError("unknown token: check that the whole token was copied (your teacher can issue a new one)")
    if row.revoked_at is not None:
        raise TokenError("revoked token: this token was revoked; ask your teacher for a new one")
    if row.teacher is not None and not row.teacher.is_active:
        raise TokenError("inactive account: the teacher account this token belongs to was deactivated")
    return row


def from_header(value: str | None) -> str | None:
    """The token in an ``Authorization: Bearer <token>`` header, None when there is no header.

    Raises:
        TokenError: a header that is not ``Bearer <token>``.
    """
    if value is None or not value.strip():
        return None
    scheme, _, token = value.strip().partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        raise TokenError("malformed Authorization header: expected 'Authorization: Bearer <token>'")
    return token.strip()
