-- The predator of the default scene: a black porgy body marked as a predator (so porgies see it
-- as one and flee) that swims faster.
return {
  base = "black_porgy",
  name = "barracuda",
  predator = true,
  decision_hz = 10,
}
