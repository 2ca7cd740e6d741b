"""Imported first by a benchmark that times the tool in its own process: BLAS on the calling thread, as every
command and test process runs it (``design.parallel.one_blas_thread``; read when numpy loads its BLAS, so this
module is imported before numpy). Without it OpenBLAS's threads spin on the tool's small matrices: a Stage Y
diagnosis took 30-50 % more CPU, and two benchmark processes on two cores each ran two BLAS threads."""

from design.parallel import one_blas_thread

one_blas_thread()
