"""The Django admin for teachers: classes, students (issue / revoke tokens), projects (ranking), results.

A teacher who is not a superuser sees only their own classes and what belongs to them. Tokens are issued by an
action on students; the new tokens are shown on the next page once and never again.
"""

from __future__ import annotations

from typing import Any

from django.contrib import admin, messages
from django.core.exceptions import ValidationError
from django.http import Http404, HttpRequest, HttpResponse
from django.shortcuts import render

from robokit.server import tokens
from robokit.server.models import (
    Artifact,
    Assignment,
    Classroom,
    ModerationEvent,
    Project,
    Result,
    Student,
    Submission,
    Token,
    TrainingRun,
)


class OwnClassesMixin:
    """Limit a non-superuser teacher to rows of the classes they own. ``owner_path`` leads to the owner.

    Another teacher's row is a 404 on every admin page that names it (change, delete, history), not Django's
    redirect to the index; list filters use :class:`admin.RelatedOnlyFieldListFilter`, which offers only the
    classes (and projects) found in the rows this teacher may see.
    """

    owner_path = "classroom__owner"

    def get_queryset(self, request: HttpRequest) -> Any:
        qs = super().get_queryset(request)  # type: ignore[misc]
        return qs if request.user.is_superuser else qs.filter(**{self.owner_path: request.user})

    def _own(self, request: HttpRequest, object_id: str | None) -> None:
        if object_id is None:
            return
        try:
            exists = self.get_queryset(request).filter(pk=object_id).exists()
        except (ValueError, ValidationError):
            exists = False
        if not exists:
            raise Http404("no such row among your classes")

    def change_view(self, request: HttpRequest, object_id: str, form_url: str = "",
                    extra_context: Any = None) -> HttpResponse:
        self._own(request, object_id)
        return super().change_view(request, object_id, form_url, extra_context)  # type: ignore[misc, no-any-return]

    def delete_view(self, request: HttpRequest, object_id: str, extra_context: Any = None) -> HttpResponse:
        self._own(request, object_id)
        return super().delete_view(request, object_id, extra_context)  # type: ignore[misc, no-any-return]

    def history_view(self, request: HttpRequest, object_id: str, extra_context: Any = None) -> HttpResponse:
        self._own(request, object_id)
        return super().history_view(request, object_id, extra_context)  # type: ignore[misc, no-any-return]

    def formfield_for_foreignkey(self, db_field: Any, request: HttpRequest, **kwargs: Any) -> Any:
        if db_field.name == "classroom" and not request.user.is_superuser:
            kwargs["queryset"] = Classroom.objects.filter(owner=request.user)
        return super().formfield_for_foreignkey(db_field, request, **kwargs)  # type: ignore[misc]


@admin.register(Classroom)
class ClassroomAdmin(OwnClassesMixin, admin.ModelAdmin):
    owner_path = "owner"
    list_display = ("name", "owner", "allow_unverified", "created_at")
    list_editable = ("allow_unverified",)

    def get_exclude(self, request: HttpRequest, obj: Any = None) -> Any:
        return () if request.user.is_superuser else ("owner",)

    def save_model(self, request: HttpRequest, obj: Any, form: Any, change: bool) -> None:
        if not change and not getattr(obj, "owner_id", None):
            obj.owner = request.user
        super().save_model(request, obj, form, change)


@admin.register(Student)
class StudentAdmin(OwnClassesMixin, admin.ModelAdmin):
    list_display = ("name", "classroom", "has_token", "created_at")
    list_filter = (("classroom", admin.RelatedOnlyFieldListFilter),)
    search_fields = ("name",)
    actions = ["issue_tokens", "revoke_tokens"]

    @admin.display(boolean=True, description="active token")
    def has_token(self, obj: Student) -> bool:
        return obj.tokens.filter(revoked_at__isnull=True).exists()

    @admin.action(description="Issue a new token (revokes the old one; shown once)")
    def issue_tokens(self, request: HttpRequest, queryset: Any) -> HttpResponse:
        issued = [(s, tokens.issue_student_token(s)) for s in queryset.select_related("classroom")]
        response = render(request, "course/tokens_issued.html", {"issued": issued})
        response["Cache-Control"] = "no-store"
        return response

    @admin.action(description="Revoke tokens")
    def revoke_tokens(self, request: HttpRequest, queryset: Any) -> None:
        n = sum(tokens.revoke_student_tokens(s) for s in queryset)
        self.message_user(request, f"{n} token(s) revoked", messages.SUCCESS)


@admin.register(Token)
class TokenAdmin(OwnClassesMixin, admin.ModelAdmin):
    list_display = ("kind", "owner_name", "classroom", "created_at", "last_used_at", "revoked_at")
    list_filter = ("kind", ("classroom", admin.RelatedOnlyFieldListFilter))
    readonly_fields = ("kind", "classroom", "student", "teacher", "created_at", "last_used_at")
    actions = ["revoke"]

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False  # tokens are issued by the student action or `robokit manage issue_token`

    @admin.action(description="Revoke")
    def revoke(self, request: HttpRequest, queryset: Any) -> None:
        from django.utils import timezone

        n = queryset.filter(revoked_at__isnull=True).update(revoked_at=timezone.now())
        self.message_user(request, f"{n} token(s) revoked", messages.SUCCESS)


@admin.register(Project)
class ProjectAdmin(OwnClassesMixin, admin.ModelAdmin):
    """A class's project and its ranking: a teacher sees and changes only their own classes' projects."""

    list_display = ("name", "classroom", "ranking", "created_at")
    list_filter = (("classroom", admin.RelatedOnlyFieldListFilter),)


class ArtifactInline(admin.TabularInline):
    model = Artifact
    extra = 0
    readonly_fields = ("name", "kind", "content_type", "size", "sha256", "path", "uploaded_at")
    can_delete = True


@admin.register(Result)
class ResultAdmin(OwnClassesMixin, admin.ModelAdmin):
    list_display = ("received_at", "student_name", "project", "classroom", "outcome", "verified", "official")
    list_filter = (("classroom", admin.RelatedOnlyFieldListFilter), ("project", admin.RelatedOnlyFieldListFilter),
                   "verified", "official", "outcome")
    search_fields = ("student_name", "posted_student", "run_id")
    readonly_fields = [f.name for f in Result._meta.fields]
    inlines = [ArtifactInline]

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False


@admin.register(Assignment)
class AssignmentAdmin(OwnClassesMixin, admin.ModelAdmin):
    """An assignment: its official config, the keys students may change, seeds, due time, late policy."""

    list_display = ("name", "classroom", "kind", "due_at", "late_policy", "allow_plugins")
    list_filter = (("classroom", admin.RelatedOnlyFieldListFilter),)
    readonly_fields = ("project",)

    def save_model(self, request: HttpRequest, obj: Any, form: Any, change: bool) -> None:
        if not obj.project_id:  # the assignment's runs board: the class's project of the same name
            obj.project, _ = Project.objects.get_or_create(classroom=obj.classroom, name=obj.name)
        super().save_model(request, obj, form, change)


@admin.register(Submission)
class SubmissionAdmin(OwnClassesMixin, admin.ModelAdmin):
    owner_path = "assignment__classroom__owner"
    list_display = ("submitted_at", "student", "assignment", "status", "success_rate", "late", "excluded")
    list_filter = ("status", "late", "excluded")
    readonly_fields = [f.name for f in Submission._meta.fields if f.name != "excluded"]

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False  # students submit with `robokit submit`


@admin.register(ModerationEvent)
class ModerationEventAdmin(OwnClassesMixin, admin.ModelAdmin):
    """The audit log: read only."""

    list_display = ("at", "teacher", "action", "what", "reason")
    readonly_fields = ("classroom", "result", "submission", "action", "reason", "teacher", "what", "at")

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.register(TrainingRun)
class TrainingRunAdmin(OwnClassesMixin, admin.ModelAdmin):
    owner_path = "student__classroom__owner"
    list_display = ("received_at", "student", "name", "run_id")
    readonly_fields = ("run_id", "student", "name", "points", "received_at")
