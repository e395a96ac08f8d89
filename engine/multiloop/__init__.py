"""Several loops at once (issue 56): a square multi-input multi-output plant under unity
negative feedback, broken at each of its inputs.  `plant`: the model, the loop seen at one
break with every other loop closed, the input sensitivity; `mu`: the structured singular
value of a diagonal complex structure at one frequency, bracketed; `hamiltonian`: where a
scaled closed loop's singular values cross a level; `disk`: the multi-loop disk margin,
certified over frequency; `loops`: loop-at-a-time and all-together analysis in one call."""
