// placeholder until the dem part lands
