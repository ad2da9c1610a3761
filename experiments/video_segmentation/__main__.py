from experiments.video_segmentation.stages import main

main()
