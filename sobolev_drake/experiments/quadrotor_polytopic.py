"""quadrotor-polytopic (thesis 6.5.3, Table 6.4) — being written by the chapter-6 experiments engineer; do not edit."""
