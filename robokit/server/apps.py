"""Django app configuration."""

from typing import Any

from django.apps import AppConfig
from django.db.models.signals import post_migrate


class CourseConfig(AppConfig):
    name = "robokit.server"
    label = "course"
    verbose_name = "Course results"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self) -> None:
        post_migrate.connect(grant_new_permissions, sender=self)


def grant_new_permissions(sender: Any, using: str = "default", **kwargs: Any) -> None:
    """After an upgrade adds models (assignments, submissions ...), teachers get their admin permissions too: every
    user who holds a permission of this app is given all of them, as ``create_teacher`` gives a new teacher."""
    from django.contrib.auth import get_user_model
    from django.contrib.auth.models import Permission

    perms = list(Permission.objects.using(using).filter(content_type__app_label="course"))
    teachers = get_user_model().objects.using(using).filter(
        user_permissions__content_type__app_label="course").distinct()
    for teacher in teachers:
        teacher.user_permissions.add(*perms)
