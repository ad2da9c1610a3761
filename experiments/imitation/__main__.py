from experiments.imitation.stages import main

main()
