"""SVG plots stored before uploads were rebuilt from a parse were kept as sent, checked only by a pattern
that a namespace prefix, ``javascript&#58;`` or ``<use href="data:...">`` got past. Rebuild each stored one the way
uploads are now (:func:`robokit.server.svg.clean_svg`), updating its size and hash; one that does not parse as an
SVG document (it would be refused today) is deleted with its row. Files already missing are left to the row."""

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Any

from django.conf import settings
from django.db import migrations


def rebuild(apps: Any, schema_editor: Any) -> None:
    from robokit.server.svg import SvgError, clean_svg

    Artifact = apps.get_model("course", "Artifact")
    for artifact in Artifact.objects.filter(content_type="image/svg+xml"):
        path = Path(settings.MEDIA_ROOT) / artifact.path
        try:
            sent = path.read_bytes()
        except FileNotFoundError:
            continue
        try:
            clean = clean_svg(sent)
        except SvgError:
            path.unlink()
            artifact.delete()
            continue
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            fh.write(clean)
        os.replace(tmp, path)
        Artifact.objects.filter(pk=artifact.pk).update(size=len(clean), sha256=hashlib.sha256(clean).hexdigest())


class Migration(migrations.Migration):

    dependencies = [
        ('course', '0004_project_classroom_required'),
    ]

    operations = [
        migrations.RunPython(rebuild, migrations.RunPython.noop),
    ]
