MODULE CalibData
	PERS tooldata smc_gripper:=[TRUE,[[0,0.004,197.001],[1,0,0,0]],[1,[0.207,-0.496,71.18],[1,0,0,0],0,0,0]];
ENDMODULE