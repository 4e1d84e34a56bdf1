"""balance-linear (thesis 6.5.2, Table 6.2) — being written by the chapter-6 experiments engineer; do not edit."""
