"""Give every project a class: a project used by several classes is copied once per class (same name, same
ranking) and each class's results move to its own copy; a project with no results belongs to no class and is
deleted (it is made again, with the default ranking, when a class first posts to it)."""

from typing import Any

from django.db import migrations


def split(apps: Any, schema_editor: Any) -> None:
    Project = apps.get_model("course", "Project")
    Result = apps.get_model("course", "Result")
    for project in Project.objects.filter(classroom__isnull=True).order_by("pk"):
        classes = sorted(set(Result.objects.filter(project=project).values_list("classroom_id", flat=True)))
        if not classes:
            project.delete()
            continue
        project.classroom_id = classes[0]
        project.save(update_fields=["classroom"])
        for classroom_id in classes[1:]:
            copy = Project.objects.create(classroom_id=classroom_id, name=project.name, ranking=project.ranking)
            Project.objects.filter(pk=copy.pk).update(created_at=project.created_at)
            Result.objects.filter(project=project, classroom_id=classroom_id).update(project=copy)


def merge(apps: Any, schema_editor: Any) -> None:
    """Back to one project per name: each name's first project keeps the results of every class."""
    Project = apps.get_model("course", "Project")
    Result = apps.get_model("course", "Result")
    first: dict[str, Any] = {}
    for project in Project.objects.order_by("pk"):
        keep = first.setdefault(project.name, project)
        if keep.pk != project.pk:
            Result.objects.filter(project=project).update(project=keep)
            project.delete()


class Migration(migrations.Migration):

    dependencies = [
        ('course', '0002_project_classroom'),
    ]

    operations = [
        migrations.RunPython(split, merge),
    ]
