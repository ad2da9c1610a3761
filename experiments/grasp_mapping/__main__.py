from experiments.grasp_mapping.stages import main

main()
