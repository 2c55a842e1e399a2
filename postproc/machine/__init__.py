"""What postproc knows about the machine and its control: the profile, the number grid, the bounds."""
