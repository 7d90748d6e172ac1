"""Django app configuration."""

from django.apps import AppConfig


class CourseConfig(AppConfig):
    name = "robokit.server"
    label = "course"
    verbose_name = "Course results"
    default_auto_field = "django.db.models.BigAutoField"
