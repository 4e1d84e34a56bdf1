"""balance-coupled (thesis 5.3.2, Table 5.7) — being written by the chapter-5 input-coupling experiments engineer; do not edit"""
