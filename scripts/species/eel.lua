-- Eel: long, slender, anguilliform (the wave runs along the whole body).
return {
  base = "eel",
  decision_hz = 5,         -- a slow, deliberate swimmer decides less often
}
