"""Pictures: pyvista off-screen renders (imported lazily) and matplotlib helpers."""
