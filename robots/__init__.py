"""Robot data: descriptions and configs. No simulation code lives here."""
