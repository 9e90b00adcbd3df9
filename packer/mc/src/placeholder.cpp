// placeholder until the mc part lands
