-- Escape (paper 3.1): a porgy that sees a predator coming turns away and outswims it.

test("fleeing increases distance from a predator", function(t)
  local w = t:world{ seed = 21 }
  local prey = w:spawn{ species = "black_porgy", pos = {100, 200, 0}, heading = math.pi, behavior = "flee" }
  local shark = w:spawn{ species = "barracuda", pos = {-150, 200, 0}, heading = 0 }
  shark:swim(60)
  local function gap()
    local a, b = prey.pos, shark.pos
    return math.sqrt((a[1] - b[1])^2 + (a[2] - b[2])^2 + (a[3] - b[3])^2)
  end
  local start = gap()
  w:run(6)
  t:greater(gap(), start, "the prey ends farther from the predator than it started")
  t:greater(assert(prey.memory).fear or 0, 0, "the prey is afraid")
end)

test("a porgy that does not flee is caught up with", function(t)
  -- The control for the test above: the same chase with a wandering porgy closes the gap.
  local w = t:world{ seed = 21 }
  local prey = w:spawn{ species = "black_porgy", pos = {100, 200, 0}, heading = math.pi }
  prey:swim(10)
  local shark = w:spawn{ species = "barracuda", pos = {-150, 200, 0}, heading = 0 }
  shark:swim(60)
  local function gap()
    local a, b = prey.pos, shark.pos
    return math.sqrt((a[1] - b[1])^2 + (a[2] - b[2])^2 + (a[3] - b[3])^2)
  end
  local start = gap()
  w:run(2)
  t:less(gap(), start, "without fleeing the gap closes")
end)
