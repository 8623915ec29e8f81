-- The default scene's own measures (scripts/scenes/default.lua: `measures`), read in a test with
-- w:measure: the mean so far over every fish and once-a-second sample that gave a value.

test("porgies keep a few body lengths from the barracuda they see, and flee part of the time", function(t)
  local w = t:world{ seed = 3, scene = "scenes/default.lua" }
  w:run(20)
  local fleeing = w:measure("fleeing")
  t:greater(fleeing, 0, "some porgies flee the patrolling barracuda")
  t:less(fleeing, 0.5, "most porgies are not fleeing at any one time")
  t:greater(w:measure("predator_distance_l"), 1, "the predator a porgy sees is more than a body length away")
end)

test("w:measure names the scene's measures when given another", function(t)
  local w = t:world{ seed = 3, scene = "scenes/default.lua" }
  w:run(1)
  local ok, err = pcall(function() return w:measure("fleing") end)
  t:expect(not ok, "an unknown measure is an error")
  t:expect(string.find(tostring(err), 'did you mean "fleeing"', 1, true), "with the closest name: " .. tostring(err))
end)
