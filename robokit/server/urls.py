"""URLs: the API under /api/robotics/, the teacher's pages, a student's own page, and the admin."""

from django.contrib import admin
from django.contrib.auth import views as auth_views
from django.urls import path

from robokit.server import api, course_api, course_pages, grades, pages, replay_page

urlpatterns = [
    path("api/robotics/result/", api.post_result, name="api-result"),
    path("api/robotics/result/<str:run_id>/artifacts/", api.post_artifacts, name="api-artifacts"),
    path("api/robotics/assignments/<str:name>/submissions/", course_api.submit, name="api-submit"),
    path("api/robotics/submissions/<int:pk>/", course_api.submission_status, name="api-submission"),
    path("api/robotics/training/", course_api.post_training, name="api-training"),
    path("", pages.home, name="home"),
    path("accounts/login/", auth_views.LoginView.as_view(), name="login"),
    path("accounts/logout/", auth_views.LogoutView.as_view(), name="logout"),
    path("classes/<int:pk>/", pages.classroom, name="classroom"),
    path("classes/<int:pk>/projects/<int:project_pk>/", pages.leaderboard, name="leaderboard"),
    path("classes/<int:pk>/students/<int:student_pk>/", pages.student_history, name="history"),
    path("classes/<int:pk>/results.csv", pages.export_csv, name="export-csv"),
    path("runs/<str:run_id>/", pages.run_detail, name="run"),
    path("artifacts/<int:pk>/<str:name>", pages.artifact_file, name="artifact"),
    path("replay/viewer.js", replay_page.viewer_js, name="replay-viewer"),
    path("replay/replay.js", replay_page.replay_js, name="replay-script"),
    path("me/", pages.me, name="me"),
    path("me/logout/", pages.me_logout, name="me-logout"),
    *course_pages.urlpatterns,
    *grades.urlpatterns,
    path("admin/", admin.site.urls),
]
