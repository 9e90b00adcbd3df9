// placeholder until the compare module lands
