"""Pure numerics: numpy/scipy only. No I/O, no Qt/VTK/pyqtgraph, no sockets, serial or processes."""
