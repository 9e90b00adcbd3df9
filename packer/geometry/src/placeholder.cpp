// placeholder until the geometry part lands
