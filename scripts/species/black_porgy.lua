-- Black porgy (Acanthopagrus schlegelii), the paper's fish: Table 1's motion parameters
-- (l = 50 world units, cruising at one body length per second) come from the built-in
-- description; override any field here and save: live fish pick it up.
return {
  base = "black_porgy",
  decision_hz = 10,        -- behaviour decisions per second
}
