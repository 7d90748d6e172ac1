# Projects are per class: the class is required and a name is unique within its class.

import django.db.models.deletion
from django.db import migrations, models


class Migration(migrations.Migration):

    dependencies = [
        ('course', '0003_split_projects_per_class'),
    ]

    operations = [
        migrations.AlterModelOptions(
            name='project',
            options={'ordering': ['name', 'classroom__name']},
        ),
        migrations.AlterField(
            model_name='project',
            name='classroom',
            field=models.ForeignKey(on_delete=django.db.models.deletion.CASCADE, related_name='projects', to='course.classroom'),
        ),
        migrations.AlterField(
            model_name='result',
            name='project',
            field=models.ForeignKey(on_delete=django.db.models.deletion.RESTRICT, related_name='results', to='course.project'),
        ),
        migrations.AddConstraint(
            model_name='project',
            constraint=models.UniqueConstraint(fields=('classroom', 'name'), name='project_name_unique_in_class'),
        ),
    ]
