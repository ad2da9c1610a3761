from experiments.real_reach.stages import main

main()
