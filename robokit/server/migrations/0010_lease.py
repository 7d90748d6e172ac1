from django.db import migrations, models


class Migration(migrations.Migration):

    dependencies = [
        ('course', '0009_fair_share'),
    ]

    operations = [
        migrations.AddField(
            model_name='submission',
            name='heartbeat',
            field=models.DateTimeField(blank=True, help_text='last sign of life of its worker', null=True),
        ),
        migrations.AddField(
            model_name='submission',
            name='note',
            field=models.CharField(blank=True, help_text='what happened to it, for the student', max_length=300),
        ),
        migrations.AddField(
            model_name='submission',
            name='requeued',
            field=models.IntegerField(default=0, help_text='times it was handed back to the queue (a worker stopped)'),
        ),
        migrations.AddField(
            model_name='submission',
            name='worker',
            field=models.CharField(blank=True, help_text='the queue process evaluating it (host:pid/pid)', max_length=200),
        ),
        migrations.AlterField(
            model_name='assignment',
            name='trial_seconds',
            field=models.FloatField(default=60.0, help_text="CPU-time budget of one trial (seconds of processor time; the config's max_time bounds its simulated time)"),
        ),
    ]
