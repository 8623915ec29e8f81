-- Black porgy (Acanthopagrus schlegelii), the paper's fish: Table 1's motion parameters
-- (l = 50 world units, cruising at one body length per second) come from the built-in
-- description; override any field here and save: live fish pick it up. For example:
--   max_speed = 120, view_range = 250, motion = { s = 60 }, drives = { hunger_per_s = 0.02 }
---@type shoal.SpeciesFile
local species = {
  base = "black_porgy",
  decision_hz = 10,        -- behaviour decisions per second (staggered over the 60 Hz tick)
}
return species
