"""The VTK 3D view: skeleton actors, floor and axes, lights, camera presets, render loop."""
