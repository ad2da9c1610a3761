from experiments.real_arm_actions.stages import main

main()
