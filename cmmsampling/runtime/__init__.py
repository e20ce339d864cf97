"""The process plumbing under the numerics: worker processes and the channel to them, BLAS
threads, the memory a run may take, and the hand-over of a panel's last run to the console
call it echoes. Nothing here knows a surface or a strategy."""
