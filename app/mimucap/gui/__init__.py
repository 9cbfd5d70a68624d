"""Qt only: main window, widgets, plots, VTK scene and wizards. No math here."""
