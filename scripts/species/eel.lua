-- Eel: long, slender, anguilliform (the wave runs along the whole body, more than one wave on
-- it; every joint bends with the same weight: power_profile = "uniform" comes from the base).
---@type shoal.SpeciesFile
local species = {
  base = "eel",
  decision_hz = 5,         -- a slow, deliberate swimmer decides less often
}
return species
