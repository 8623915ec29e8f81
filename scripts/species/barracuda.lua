-- The predator of the default scene: the black porgy's body scaled up to 1.6 times the length,
-- tinted rust-red, marked as a predator (porgies see it as one and flee), faster and
-- farther-sighted.
---@type shoal.SpeciesFile
local species = {
  base = "black_porgy",
  name = "barracuda",
  predator = true,
  color_tint = { 1.3, 0.75, 0.55 },
  motion = {
    l = 80,                 -- body length, world units (the model is scaled to it)
    s = 70,                 -- cruising speed, units/s
    max_amp = 80 * 0.16,    -- the porgy's 0.16 l: the tail sweeps ~0.2 L peak to peak
    lambda = 80 * 1.2,      -- the porgy's 1.2 body lengths (a ~1 L wave on the posed body)
  },
  view_range = 500,
  max_speed = 170,
  decision_hz = 10,
}
return species
