from django.db import migrations, models


class Migration(migrations.Migration):

    dependencies = [
        ('course', '0008_student_plugins'),
    ]

    operations = [
        migrations.AddField(
            model_name='assignment',
            name='max_per_day',
            field=models.PositiveIntegerField(default=10, help_text='submissions a student may make in any 24 hours (0: no limit)'),
        ),
        migrations.AddField(
            model_name='assignment',
            name='max_waiting',
            field=models.PositiveIntegerField(default=1, help_text='submissions a student may have queued or being evaluated at once'),
        ),
        migrations.AddField(
            model_name='submission',
            name='claim',
            field=models.BigIntegerField(blank=True, db_index=True, help_text='the queue task evaluating it (see robokit.server.fair_queue)', null=True),
        ),
        migrations.AddField(
            model_name='submission',
            name='claimed_at',
            field=models.DateTimeField(blank=True, help_text='when a worker took it up', null=True),
        ),
        migrations.AddField(
            model_name='submission',
            name='idempotency_key',
            field=models.CharField(blank=True, help_text="the post's Idempotency-Key: the same key is the same submission", max_length=64, null=True),
        ),
        migrations.AlterField(
            model_name='moderationevent',
            name='action',
            field=models.CharField(choices=[('exclude', 'exclude'), ('include', 'include'), ('reevaluate', 'reevaluate')], max_length=10),
        ),
        migrations.AddConstraint(
            model_name='submission',
            constraint=models.UniqueConstraint(fields=('student', 'idempotency_key'), name='submission_key_unique_per_student'),
        ),
    ]
