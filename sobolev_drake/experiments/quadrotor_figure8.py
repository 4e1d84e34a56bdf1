"""quadrotor-figure8 (thesis 5.3.2, Table 5.9) — being written by the chapter-5 input-coupling experiments engineer; do not edit"""
